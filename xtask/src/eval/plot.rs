//! Minimal SVG scatter plots (no plotting dependency): log or linear axes, labelled points,
//! a highlighted Pareto front, an optional `y = x` diagonal, and lines through series.

use std::fmt::Write;

/// One point of a scatter plot.
#[derive(Clone, Debug)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub label: String,
    /// Points of one series share a colour (and are joined when `lines` is set).
    pub series: String,
}

/// What to draw.
#[derive(Clone, Debug, Default)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    /// Mark the Pareto front (minimal x and minimal y).
    pub pareto: bool,
    /// Draw `y = x`.
    pub diagonal: bool,
    /// Join the points of each series in x order.
    pub lines: bool,
    /// Write each point's label next to it.
    pub labels: bool,
    pub points: Vec<Point>,
}

const W: f64 = 720.0;
const H: f64 = 440.0;
const L: f64 = 70.0;
const R: f64 = 170.0;
const T: f64 = 36.0;
const B: f64 = 50.0;

const PALETTE: [&str; 10] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
    "#7f7f7f", "#bcbd22",
];

/// `s` with `&`, `<` and `>` escaped for HTML and SVG text.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Indices of the points on the Pareto front (no other point is at most as large in both
/// coordinates and smaller in one), sorted by x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best_y = f64::INFINITY;
    for i in idx {
        if points[i].1 < best_y {
            best_y = points[i].1;
            front.push(i);
        }
    }
    front
}

impl Plot {
    /// The plot as a standalone SVG document.
    pub fn svg(&self) -> String {
        let pts: Vec<&Point> = self
            .points
            .iter()
            .filter(|p| {
                p.x.is_finite()
                    && p.y.is_finite()
                    && (!self.log_x || p.x > 0.0)
                    && (!self.log_y || p.y > 0.0)
            })
            .collect();
        let tx = |v: f64| if self.log_x { v.log10() } else { v };
        let ty = |v: f64| if self.log_y { v.log10() } else { v };
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in &pts {
            x0 = x0.min(tx(p.x));
            x1 = x1.max(tx(p.x));
            y0 = y0.min(ty(p.y));
            y1 = y1.max(ty(p.y));
        }
        if pts.is_empty() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        if self.diagonal {
            let lo = x0.min(y0);
            let hi = x1.max(y1);
            (x0, x1, y0, y1) = (lo, hi, lo, hi);
        }
        let pad = |a: f64, b: f64| {
            let d = (b - a).abs().max(1e-9 * a.abs().max(1.0)).max(1e-12);
            (a - 0.06 * d, b + 0.06 * d)
        };
        let (x0, x1) = pad(x0, x1);
        let (y0, y1) = pad(y0, y1);
        let sx = |v: f64| L + (tx(v) - x0) / (x1 - x0) * (W - L - R);
        let sy = |v: f64| H - B - (ty(v) - y0) / (y1 - y0) * (H - T - B);

        let mut s = String::new();
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {H}" width="{W}" height="{H}" font-family="sans-serif" font-size="11">"#
        );
        let _ = write!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
        let _ = write!(
            s,
            r#"<text x="{}" y="20" font-size="14" text-anchor="middle">{}</text>"#,
            (L + W - R) / 2.0,
            esc(&self.title)
        );
        // Axes and ticks.
        let _ = write!(
            s,
            r##"<rect x="{L}" y="{T}" width="{}" height="{}" fill="none" stroke="#444"/>"##,
            W - L - R,
            H - T - B
        );
        for k in 0..=4 {
            let f = k as f64 / 4.0;
            let vx = x0 + f * (x1 - x0);
            let vy = y0 + f * (y1 - y0);
            let (px, py) = (L + f * (W - L - R), H - B - f * (H - T - B));
            let lx = if self.log_x { 10f64.powf(vx) } else { vx };
            let ly = if self.log_y { 10f64.powf(vy) } else { vy };
            let _ = write!(
                s,
                r##"<line x1="{px}" y1="{T}" x2="{px}" y2="{}" stroke="#eee"/><text x="{px}" y="{}" text-anchor="middle">{}</text>"##,
                H - B,
                H - B + 15.0,
                fmt_num(lx)
            );
            let _ = write!(
                s,
                r##"<line x1="{L}" y1="{py}" x2="{}" y2="{py}" stroke="#eee"/><text x="{}" y="{}" text-anchor="end">{}</text>"##,
                W - R,
                L - 5.0,
                py + 4.0,
                fmt_num(ly)
            );
        }
        let _ = write!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            (L + W - R) / 2.0,
            H - 12.0,
            esc(&format!(
                "{}{}",
                self.x_label,
                if self.log_x { " (log)" } else { "" }
            ))
        );
        let _ = write!(
            s,
            r#"<text x="16" y="{}" text-anchor="middle" transform="rotate(-90 16 {})">{}</text>"#,
            (T + H - B) / 2.0,
            (T + H - B) / 2.0,
            esc(&format!(
                "{}{}",
                self.y_label,
                if self.log_y { " (log)" } else { "" }
            ))
        );
        if self.diagonal {
            let a = if self.log_x { 10f64.powf(x0) } else { x0 };
            let b = if self.log_x { 10f64.powf(x1) } else { x1 };
            let _ = write!(
                s,
                r##"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="#999" stroke-dasharray="4 3"/>"##,
                sx(a),
                sy(a),
                sx(b),
                sy(b)
            );
        }
        // Series colours in order of first appearance.
        let mut series: Vec<&str> = Vec::new();
        for p in &pts {
            if !series.contains(&p.series.as_str()) {
                series.push(&p.series);
            }
        }
        let colour = |name: &str| {
            let i = series.iter().position(|s| *s == name).unwrap_or(0);
            PALETTE[i % PALETTE.len()]
        };
        if self.lines {
            for name in &series {
                let mut sp: Vec<&&Point> = pts.iter().filter(|p| p.series == *name).collect();
                sp.sort_by(|a, b| a.x.total_cmp(&b.x));
                let path: Vec<String> = sp
                    .iter()
                    .map(|p| format!("{:.1},{:.1}", sx(p.x), sy(p.y)))
                    .collect();
                let _ = write!(
                    s,
                    r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.5"/>"#,
                    path.join(" "),
                    colour(name)
                );
            }
        }
        if self.pareto {
            let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.x, p.y)).collect();
            let front = pareto_front(&xy);
            let path: Vec<String> = front
                .iter()
                .map(|&i| format!("{:.1},{:.1}", sx(pts[i].x), sy(pts[i].y)))
                .collect();
            let _ = write!(
                s,
                r##"<polyline points="{}" fill="none" stroke="#000" stroke-width="1" stroke-dasharray="5 3"/>"##,
                path.join(" ")
            );
            for &i in &front {
                let _ = write!(
                    s,
                    r##"<circle cx="{:.1}" cy="{:.1}" r="7" fill="none" stroke="#000"/>"##,
                    sx(pts[i].x),
                    sy(pts[i].y)
                );
            }
        }
        for p in &pts {
            let _ = write!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{}"><title>{}</title></circle>"#,
                sx(p.x),
                sy(p.y),
                colour(&p.series),
                esc(&format!(
                    "{}: ({}, {})",
                    p.label,
                    fmt_num(p.x),
                    fmt_num(p.y)
                ))
            );
            if self.labels {
                let _ = write!(
                    s,
                    r##"<text x="{:.1}" y="{:.1}" fill="#333" font-size="9">{}</text>"##,
                    sx(p.x) + 6.0,
                    sy(p.y) - 5.0,
                    esc(&p.label)
                );
            }
        }
        // Legend.
        for (i, name) in series.iter().enumerate() {
            let y = T + 10.0 + 16.0 * i as f64;
            let _ = write!(
                s,
                r#"<circle cx="{}" cy="{y}" r="4" fill="{}"/><text x="{}" y="{}">{}</text>"#,
                W - R + 14.0,
                colour(name),
                W - R + 24.0,
                y + 4.0,
                esc(name)
            );
        }
        if self.pareto {
            let y = T + 10.0 + 16.0 * series.len() as f64;
            let _ = write!(
                s,
                r#"<circle cx="{}" cy="{y}" r="7" fill="none" stroke="black"/><text x="{}" y="{}">Pareto front</text>"#,
                W - R + 14.0,
                W - R + 24.0,
                y + 4.0
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

/// A compact number for tick labels.
pub fn fmt_num(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.3}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (0.5, 9.0)];
        assert_eq!(pareto_front(&pts), vec![4, 0, 1, 3]);
    }

    #[test]
    fn svg_is_well_formed_enough() {
        let p = Plot {
            title: "t <x>".into(),
            log_x: true,
            pareto: true,
            points: vec![
                Point {
                    x: 1.0,
                    y: 2.0,
                    label: "a".into(),
                    series: "s".into(),
                },
                Point {
                    x: 10.0,
                    y: 1.0,
                    label: "b".into(),
                    series: "s".into(),
                },
            ],
            ..Default::default()
        };
        let s = p.svg();
        assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
        assert!(s.contains("t &lt;x&gt;"));
    }
}
