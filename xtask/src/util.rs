//! Helpers shared by the commands: thread pools, timing statistics, CPU time, the machine and
//! commit of a run, output folders and dates, geometric means and file names, scene loading.

use anyhow::{Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Runs `f` in a rayon pool of `threads` threads (all cores when `None`).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    Ok(pool(threads)?.install(f))
}

/// A rayon pool of `threads` threads (all cores when `None`), to be reused: a benchmark that
/// times several runs keeps one pool, as a renderer does and as Embree keeps its threads, so
/// that no run starts on freshly spawned, cold threads.
pub fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        b = b.num_threads(n.max(1));
    }
    b.build().context("creating the thread pool")
}

/// The thread count a pool would get.
pub fn thread_count(threads: Option<usize>) -> usize {
    threads.unwrap_or_else(rayon::current_num_threads)
}

/// Median, minimum and maximum of repeated measurements.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Spread {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Spread {
    pub fn of(samples: &[f64]) -> Spread {
        let t = sahara_trace::Timing::from_samples(samples);
        Spread {
            median: t.median,
            min: t.min,
            max: t.max,
        }
    }

    pub fn map(self, f: impl Fn(f64) -> f64) -> Spread {
        let (a, b) = (f(self.min), f(self.max));
        Spread {
            median: f(self.median),
            min: a.min(b),
            max: a.max(b),
        }
    }
}

/// Runs `f` `runs` times and returns the wall-clock seconds of each run plus the last result.
pub fn time_runs<T>(runs: usize, mut f: impl FnMut() -> T) -> (Vec<f64>, T) {
    let mut times = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs.max(1) {
        let t0 = Instant::now();
        let r = f();
        times.push(t0.elapsed().as_secs_f64());
        last = Some(r);
    }
    (times, last.expect("at least one run"))
}

/// CPU time of this process so far (user + system, all threads), in milliseconds, from
/// `/proc/self/stat` at 100 clock ticks per second; NaN where that file does not exist.
pub fn cpu_ms() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    // The fields after the command name, which is in parentheses and may hold spaces.
    let after = &stat[stat.rfind(')').map_or(0, |i| i + 2)..];
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| {
        f.get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    (ticks(11) + ticks(12)) * 10.0
}

/// The CPU's model name (for reports).
pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

/// The current git commit (short), or "unknown".
pub fn git_commit() -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into())
}

/// The output folder of a run: `given` (`--out`), else `<workspace>/<folder>/<name>`.
pub fn out_dir(given: Option<&Path>, folder: &str, name: &str) -> PathBuf {
    if let Some(o) = given {
        return o.to_path_buf();
    }
    let root = sahara_scene::workspace_root().unwrap_or_else(|| PathBuf::from("."));
    root.join(folder).join(name)
}

/// Seconds since 1970-01-01 UTC, from the system clock.
fn unix_seconds() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0)
}

/// Now, `YYYY-MM-DDTHH-MM-SS` in UTC (no date crate needed).
pub fn utc_stamp() -> String {
    let secs = unix_seconds();
    let rem = secs % 86_400;
    format!(
        "{}T{:02}-{:02}-{:02}",
        civil_date(secs / 86_400),
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

/// Today's UTC date, `YYYY-MM-DD`.
pub fn utc_date() -> String {
    civil_date(unix_seconds() / 86_400)
}

/// The civil date `YYYY-MM-DD` of a day counted from 1970-01-01 (Howard Hinnant's
/// civil-from-days).
fn civil_date(days: u64) -> String {
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!("{y:04}-{m:02}-{d:02}")
}

/// Geometric mean of the positive, finite values of `v`; `None` when there is none.
pub fn geomean(v: &[f64]) -> Option<f64> {
    let v: Vec<f64> = v
        .iter()
        .copied()
        .filter(|x| *x > 0.0 && x.is_finite())
        .collect();
    if v.is_empty() {
        return None;
    }
    Some((v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp())
}

/// `name` with every character other than ASCII letters, digits, `-` and `_` replaced by `_`,
/// for file names.
pub fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The catalog's scene files, one per model (an engine's GLB of a model that also has an OBJ
/// is left out: traced once), with their triangle counts where the catalog knows them.
pub fn scene_files(catalog: &sahara_scene::Catalog) -> Vec<(String, Option<usize>)> {
    catalog
        .distinct_files()
        .into_iter()
        .map(|e| (e.name.clone(), e.triangles))
        .collect()
}

/// Builds the registry preset `name`.
pub fn builder(name: &str) -> Result<Box<dyn sahara_builders::Builder>> {
    // obvhs's PLOC tree, converted (feature `obvhs`; not in the builders' registry).
    #[cfg(feature = "obvhs")]
    if name == crate::engine::obvhs::PLOC_NAME {
        return Ok(Box::new(crate::engine::obvhs::PlocBuilder));
    }
    // Embree's binned and spatial-split trees, converted (feature `embree`).
    #[cfg(feature = "embree")]
    if let Some(b) = crate::engine::embree_tree::EmbreeTreeBuilder::by_name(name) {
        return Ok(Box::new(b));
    }
    sahara_builders::registry::by_name(name).with_context(|| {
        format!(
            "unknown builder '{name}'; known: {}",
            sahara_builders::registry::names().join(", ")
        )
    })
}

/// A scene ready for building and tracing.
pub struct LoadedScene {
    pub name: String,
    pub triangles: Vec<sahara_geom::Triangle>,
    pub camera: sahara_scene::Camera,
    /// Where `camera` comes from, for reports: `generator`, `cameras.tsv`, `framing`,
    /// `command line` or `placed (interior, 83% good rays)` (docs/cameras.md).
    pub camera_source: String,
}

/// Loads a catalog scene by name (or a path) and converts it to triangles.
pub fn load_scene(name: &str) -> Result<LoadedScene> {
    let catalog = sahara_scene::Catalog::discover();
    load_scene_from(&catalog, name)
}

/// As [`load_scene`], with a catalog already discovered.
pub fn load_scene_from(catalog: &sahara_scene::Catalog, name: &str) -> Result<LoadedScene> {
    load_scene_with(catalog, name, None)
}

/// As [`load_scene_from`], with the camera `camera` if given (`--camera`). Without one, a
/// scene given by path (not a catalog name) that has no camera of its own (no row in a
/// `cameras.tsv` beside it, nor among the named scenes) gets a placed camera
/// ([`placed_camera`]); catalog scenes keep theirs (the framing, for those without one, so
/// that published results stay comparable).
pub fn load_scene_with(
    catalog: &sahara_scene::Catalog,
    name: &str,
    camera: Option<&sahara_scene::Camera>,
) -> Result<LoadedScene> {
    let scene = catalog
        .load(name)
        .with_context(|| format!("loading scene '{name}'"))?;
    let triangles = scene.triangles();
    let by_path = catalog.get(name).is_none();
    let (camera, camera_source) = match camera {
        Some(c) => (*c, sahara_scene::CameraSource::Given.to_string()),
        None if by_path && scene.camera_source == sahara_scene::CameraSource::Framing => {
            let (c, label) = placed_camera(&triangles)?;
            eprintln!("{}: no camera known, {label}: {c}", scene.name);
            (c, label)
        }
        None => (scene.camera, scene.camera_source.to_string()),
    };
    Ok(LoadedScene {
        triangles,
        camera,
        camera_source,
        name: scene.name,
    })
}

/// A camera placed for `tris` (docs/cameras.md): the up axis detected from the triangles'
/// normals (`UpAxis::detect`), then `sahara_trace::place_camera` over a binned-SAH tree.
/// Returns the camera and a label for reports (`placed (interior, 83% good rays)`).
pub fn placed_camera(tris: &[sahara_geom::Triangle]) -> Result<(sahara_scene::Camera, String)> {
    let up = sahara_scene::UpAxis::detect(tris);
    let input = sahara_builders::BuildInput::new(tris, sahara_builders::CostModel::default())?;
    let bvh = builder("binned")?.build(&input)?;
    let p = sahara_trace::place_camera(
        &sahara_trace::Bvh2Tracer::new(&bvh, tris),
        tris,
        up.vector(),
    );
    let kind = match p.kind {
        sahara_trace::PlacementKind::Interior => "interior",
        sahara_trace::PlacementKind::Exterior => "exterior",
    };
    let c = p.camera;
    Ok((
        c,
        format!(
            "placed ({kind}, {:?} up, {:.0}% good rays)",
            up,
            100.0 * p.score
        ),
    ))
}

/// Parses `--camera` (`eye=x,y,z target=x,y,z up=x,y,z fov=deg`) for clap.
pub fn parse_camera(s: &str) -> std::result::Result<sahara_scene::Camera, String> {
    s.parse::<sahara_scene::Camera>().map_err(|e| e.to_string())
}

/// Prints `== {what}: ok in N s` (`FAILED` when `status` is not a success), N the seconds
/// since `t0`, the last line of one run of the `miri` and `sanitize` commands; returns
/// whether the run succeeded.
pub fn report_status(status: std::process::ExitStatus, t0: Instant, what: &str) -> bool {
    eprintln!(
        "== {what}: {} in {:.0} s",
        if status.success() { "ok" } else { "FAILED" },
        t0.elapsed().as_secs_f64()
    );
    status.success()
}

/// Asserts that every `(package, test file)` of a command's suite list exists as
/// `crates/<package without "sahara-">/tests/<test>.rs`, so that a renamed test file cannot
/// drop out of `verify` or `miri` silently.
#[cfg(test)]
pub fn assert_suites_exist(suites: &[(&str, &str)]) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for (package, test) in suites {
        let dir = package.strip_prefix("sahara-").expect("a sahara-* package");
        let file = root
            .join("crates")
            .join(dir)
            .join("tests")
            .join(format!("{test}.rs"));
        assert!(
            file.is_file(),
            "{package} --test {test}: no {}",
            file.display()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(59), "1970-03-01");
        assert_eq!(civil_date(11_016), "2000-02-29");
        assert_eq!(civil_date(20_794), "2026-12-07");
    }

    #[test]
    fn geometric_means_skip_what_has_no_logarithm() {
        assert_eq!(geomean(&[]), None);
        assert_eq!(geomean(&[0.0, -1.0, f64::NAN]), None);
        assert!((geomean(&[2.0, 8.0, 0.0]).unwrap() - 4.0).abs() < 1e-12);
    }
}
