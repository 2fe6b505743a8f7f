//! The document and its two renderings: Markdown, and self-contained HTML with the SVG
//! plots inline and the PNG images embedded as data URLs.

use super::*;

/// A piece of the report, rendered both as Markdown and as HTML.
pub(super) enum Block {
    Heading(u8, String),
    /// A paragraph; `**bold**` and `` `code` `` are marked up in HTML.
    Para(String),
    /// Head and rows; the first column is left-aligned, the others right-aligned.
    Table(Vec<String>, Vec<Vec<String>>),
    /// Head and rows of prose, every column left-aligned.
    TextTable(Vec<String>, Vec<Vec<String>>),
    /// An SVG plot: file name (relative to the report), alt text, document.
    Svg {
        path: String,
        alt: String,
        svg: String,
    },
    /// A row of images (file name relative to the report, caption).
    Gallery(Vec<(String, String)>),
}

#[derive(Default)]
pub(super) struct Doc {
    pub(super) blocks: Vec<Block>,
}

impl Doc {
    pub(super) fn h(&mut self, level: u8, s: impl Into<String>) {
        self.blocks.push(Block::Heading(level, s.into()));
    }

    pub(super) fn p(&mut self, s: impl Into<String>) {
        self.blocks.push(Block::Para(s.into()));
    }

    pub(super) fn table<S: Into<String>>(
        &mut self,
        head: impl IntoIterator<Item = S>,
        rows: Vec<Vec<String>>,
    ) {
        let head = head.into_iter().map(Into::into).collect();
        self.blocks.push(Block::Table(head, rows));
    }

    pub(super) fn text_table(&mut self, head: Vec<String>, rows: Vec<Vec<String>>) {
        self.blocks.push(Block::TextTable(head, rows));
    }

    /// `plot`, saved as `path` (written by [`write_all`]) and drawn inline in HTML.
    pub(super) fn svg(&mut self, path: impl Into<String>, alt: impl Into<String>, plot: Plot) {
        self.blocks.push(Block::Svg {
            path: path.into(),
            alt: alt.into(),
            svg: plot.svg(),
        });
    }

    pub(super) fn gallery(&mut self, items: Vec<(String, String)>) {
        self.blocks.push(Block::Gallery(items));
    }

    pub(super) fn markdown(&self) -> String {
        let mut s = String::new();
        for b in &self.blocks {
            b.markdown(&mut s);
        }
        s
    }

    /// The HTML page; images are read from `dir` and embedded.
    pub(super) fn html(&self, dir: &Path) -> String {
        let mut s = String::from(HTML_HEAD);
        for b in &self.blocks {
            b.html(&mut s, dir);
        }
        s.push_str("</body></html>\n");
        s
    }
}

/// The HTML page up to its first block.
pub(super) const HTML_HEAD: &str = r#"<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>sahara evaluation</title>
<style>
body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:13px}
th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}
th:first-child,td:first-child{text-align:left}
table.text th,table.text td{text-align:left;vertical-align:top}
th{background:#f3f3f3}
img{max-width:100%;image-rendering:pixelated;border:1px solid #ddd}
.gallery{display:flex;flex-wrap:wrap;gap:10px}
.gallery figure{margin:0;width:230px}
figcaption{font-size:12px;text-align:center}
code{background:#f5f5f5;padding:1px 3px}
</style></head><body>
"#;

impl Block {
    /// Appends the block as Markdown.
    pub(super) fn markdown(&self, s: &mut String) {
        match self {
            Block::Heading(l, t) => {
                let _ = writeln!(s, "{} {t}\n", "#".repeat(*l as usize));
            }
            Block::Para(t) => {
                let _ = writeln!(s, "{t}\n");
            }
            Block::Table(head, rows) | Block::TextTable(head, rows) => {
                let text = matches!(self, Block::TextTable(..));
                let _ = writeln!(s, "| {} |", head.join(" | "));
                let rule: Vec<&str> = (0..head.len())
                    .map(|i| if i == 0 || text { "---" } else { "---:" })
                    .collect();
                let _ = writeln!(s, "|{}|", rule.join("|"));
                for r in rows {
                    let _ = writeln!(s, "| {} |", r.join(" | "));
                }
                s.push('\n');
            }
            Block::Svg { path, alt, .. } => {
                let _ = writeln!(s, "![{alt}]({path})\n");
            }
            Block::Gallery(items) => {
                for (path, cap) in items {
                    let _ = write!(s, "![{cap}]({path}) ");
                }
                s.push_str("\n\n");
                let caps: Vec<&str> = items.iter().map(|(_, c)| c.as_str()).collect();
                let _ = writeln!(s, "*{}*\n", caps.join(" · "));
            }
        }
    }

    /// Appends the block as HTML (images read from `dir`).
    pub(super) fn html(&self, s: &mut String, dir: &Path) {
        match self {
            Block::Heading(l, t) => {
                let _ = writeln!(s, "<h{l}>{}</h{l}>", esc(t));
            }
            Block::Para(t) => {
                let _ = writeln!(s, "<p>{}</p>", inline_md(&esc(t)));
            }
            Block::Table(head, rows) | Block::TextTable(head, rows) => {
                s.push_str(if matches!(self, Block::TextTable(..)) {
                    "<table class=\"text\"><thead><tr>"
                } else {
                    "<table><thead><tr>"
                });
                for h in head {
                    let _ = write!(s, "<th>{}</th>", esc(h));
                }
                s.push_str("</tr></thead><tbody>\n");
                for r in rows {
                    s.push_str("<tr>");
                    for c in r {
                        let _ = write!(s, "<td>{}</td>", inline_md(&esc(c)));
                    }
                    s.push_str("</tr>\n");
                }
                s.push_str("</tbody></table>\n");
            }
            Block::Svg { svg, .. } => {
                let _ = writeln!(s, "<div class=\"plot\">{svg}</div>");
            }
            Block::Gallery(items) => {
                s.push_str("<div class=\"gallery\">");
                for (path, cap) in items {
                    let _ = write!(
                        s,
                        "<figure>{}<figcaption>{}</figcaption></figure>",
                        embedded_image(dir, path, cap),
                        esc(cap)
                    );
                }
                s.push_str("</div>\n");
            }
        }
    }
}

/// The PNG at `dir/path` as an `<img>` with a data URL (a note when it cannot be read).
pub(super) fn embedded_image(dir: &Path, path: &str, alt: &str) -> String {
    match std::fs::read(dir.join(path)) {
        Ok(bytes) => format!(
            r#"<img alt="{}" src="data:image/png;base64,{}">"#,
            esc(alt),
            base64::engine::general_purpose::STANDARD.encode(bytes)
        ),
        Err(_) => format!("<em>missing image {}</em>", esc(path)),
    }
}

/// `**bold**` and `` `code` `` in already escaped text.
pub(super) fn inline_md(t: &str) -> String {
    let mut out = String::new();
    let mut bold = false;
    let mut code = false;
    let mut chars = t.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '*' && chars.peek() == Some(&'*') {
            chars.next();
            out.push_str(if bold { "</b>" } else { "<b>" });
            bold = !bold;
        } else if c == '`' {
            out.push_str(if code { "</code>" } else { "<code>" });
            code = !code;
        } else {
            out.push(c);
        }
    }
    out
}
