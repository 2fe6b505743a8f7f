//! Running a case against builders and kernels.

use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rayon::prelude::*;
use sahara_builders::{registry::Entry, BuildError, BuildInput, Builder, Bvh, CostModel};
use sahara_geom::{Ray, Triangle};
use sahara_traverse::{brute, scalar, Backend, Hit, NoStats, WideBvh};

use crate::{catch_quiet, known_bug_for, Case, Category, Kernel, Outcome};

/// How [`run_case_with`] runs.
#[derive(Clone, Debug)]
pub struct Options {
    /// Time allowed for everything one builder does on one case (builds, validation, every
    /// kernel); past it the builder is reported as `timeout` and its thread is abandoned.
    pub timeout: Duration,
    /// Builders registered as `small_inputs_only` are skipped above this many triangles.
    pub small_input_limit: usize,
    /// Honour [`Case::check_determinism`] (false: never rebuild).
    pub determinism: bool,
    /// Print one progress line per builder to stderr.
    pub verbose: bool,
    /// Builders skipped on inputs above [`Options::large_input`] triangles (the xtask's
    /// `--full` run fills it from a calibration build: builders that need seconds for 20 000
    /// triangles would need hours for a million).
    pub slow_builders: Vec<String>,
    /// See [`Options::slow_builders`].
    pub large_input: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            timeout: Duration::from_secs(300),
            small_input_limit: 2000,
            determinism: true,
            verbose: false,
            slow_builders: Vec::new(),
            large_input: 100_000,
        }
    }
}

/// Runs `case` against each builder of `builders` and each kernel of `kernels` with the
/// default [`Options`]. See [`run_case_with`].
pub fn run_case(case: &Case, builders: &[Entry], kernels: &[Kernel]) -> Vec<Outcome> {
    run_case_with(case, builders, kernels, &Options::default())
}

/// Runs `case`: checks the input (`input`: accepted, or rejected with the expected
/// [`BuildError::NonFinite`]), the brute-force reference (`brute`: no panic, the rays that
/// must hit do, invalid rays miss), then for each builder, in its own thread under a time
/// limit, the build (`builder`: no panic, a tree that validates or a typed error for bad
/// geometry, finite SAH, file round trip, bit-identical rebuilds on 1 and 2 threads), and for
/// each kernel (`builder/kernel`): closest hit and any hit bit-identical to brute force ray by
/// ray, and no miss among the rays that must hit.
pub fn run_case_with(
    case: &Case,
    builders: &[Entry],
    kernels: &[Kernel],
    opts: &Options,
) -> Vec<Outcome> {
    let mut out = Vec::new();
    let tris = Arc::clone(&case.triangles);
    let input_start = Instant::now();
    let input = catch_quiet(|| BuildInput::new(&tris, CostModel::default()).map(|_| ()));
    let input_secs = input_start.elapsed().as_secs_f64();
    let (ok, detail) = match (&input, case.expect_non_finite) {
        (Err(p), _) => (false, format!("BuildInput::new panicked: {p}")),
        (Ok(Ok(())), None) => (true, "ok".to_string()),
        (Ok(Ok(())), Some(i)) => (
            false,
            format!("accepted non-finite input (expected NonFinite {{ triangle: {i} }})"),
        ),
        (Ok(Err(BuildError::NonFinite { triangle })), Some(i)) if *triangle == i => {
            (true, format!("ok: NonFinite {{ triangle: {i} }}"))
        }
        (Ok(Err(e)), _) => (false, format!("unexpected error: {e:?}")),
    };
    out.push(outcome(case, "input", None, None, ok, detail, input_secs));
    if !matches!(input, Ok(Ok(()))) {
        return finish(out);
    }

    // The brute-force reference.
    let rays = Arc::new(case.rays.clone());
    let start = Instant::now();
    let reference = catch_quiet(|| {
        let closest: Vec<Hit> = rays
            .par_iter()
            .map(|r| brute::closest_hit(&tris, r))
            .collect();
        let any: Vec<bool> = rays.par_iter().map(|r| brute::any_hit(&tris, r)).collect();
        Reference { closest, any }
    });
    let secs = start.elapsed().as_secs_f64();
    let reference = match reference {
        Ok(r) => Arc::new(r),
        Err(p) => {
            out.push(outcome(case, "brute", None, None, false, p, secs));
            return finish(out);
        }
    };
    let (ok, detail) = check_brute(case, &reference);
    out.push(outcome(case, "brute", None, None, ok, detail, secs));
    if case.oracle {
        // The reference pinned by the exact oracle (which shares no code with it).
        let start = Instant::now();
        let judged = catch_quiet(|| {
            let oracle = crate::pinning::oracle_for(&tris);
            (
                crate::pinning::pin_closest(&oracle, &rays, &reference.closest),
                crate::pinning::pin_any(&oracle, &rays, &reference.any),
            )
        });
        let secs = start.elapsed().as_secs_f64();
        let (ok, detail) = match judged {
            Ok((c, a)) => {
                let ok = c.failures() + a.failures() == 0;
                let mut d = format!("closest hit: {c}; any hit: {a}");
                if let Some(f) = c.first_failure.as_ref().or(a.first_failure.as_ref()) {
                    d.push_str(&format!(" (first failure: {f})"));
                }
                (ok, d)
            }
            Err(p) => (false, p),
        };
        out.push(outcome(case, "oracle", None, None, ok, detail, secs));
    }

    for entry in builders {
        let name = entry.name.to_string();
        let skip = if entry.small_inputs_only && tris.len() > opts.small_input_limit {
            Some(format!(
                "skip: small_inputs_only and {} > {} triangles",
                tris.len(),
                opts.small_input_limit
            ))
        } else if tris.len() > opts.large_input
            && opts.slow_builders.iter().any(|b| b == entry.name)
        {
            Some(format!(
                "skip: slow builder on {} > {} triangles",
                tris.len(),
                opts.large_input
            ))
        } else if case
            .only_builders
            .as_ref()
            .is_some_and(|only| !only.iter().any(|b| b == entry.name))
        {
            Some("skip: not run on this case (too large)".to_string())
        } else {
            None
        };
        if let Some(why) = skip {
            let mut o = outcome(case, &name, Some(&name), None, true, why, 0.0);
            o.skipped = true;
            out.push(o);
            continue;
        }
        let job = Job {
            case_name: case.name.clone(),
            category: case.category,
            builder: name.clone(),
            make: entry.make,
            tris: Arc::clone(&tris),
            rays: Arc::clone(&rays),
            reference: Arc::clone(&reference),
            must_hit: case.must_hit,
            determinism: case.check_determinism && opts.determinism,
            kernels: kernels.to_vec(),
            stage: Arc::new(Mutex::new("starting".to_string())),
        };
        let stage = Arc::clone(&job.stage);
        let stage_now = || stage.lock().map(|s| s.clone()).unwrap_or_default();
        // The builder's thread failed: one outcome, charged to the builder.
        let failure = |detail: String, seconds: f64| {
            outcome(case, &name, Some(&name), None, false, detail, seconds)
        };
        let (tx, rx) = mpsc::channel();
        let start = Instant::now();
        let spawned = std::thread::Builder::new()
            .name(format!("hardcases-{name}"))
            .spawn(move || {
                let r = job.run();
                let _ = tx.send(r);
            });
        if let Err(e) = spawned {
            out.push(failure(format!("could not spawn a thread: {e}"), 0.0));
            continue;
        }
        let result = rx.recv_timeout(opts.timeout);
        let results = match result {
            Ok(r) => r,
            Err(mpsc::RecvTimeoutError::Timeout) => vec![failure(
                format!(
                    "timeout after {} s ({})",
                    opts.timeout.as_secs(),
                    stage_now()
                ),
                opts.timeout.as_secs_f64(),
            )],
            Err(mpsc::RecvTimeoutError::Disconnected) => vec![failure(
                format!("builder thread died ({})", stage_now()),
                start.elapsed().as_secs_f64(),
            )],
        };
        if opts.verbose {
            let failed = results.iter().filter(|o| !o.passed).count();
            eprintln!(
                "  {:<40} {:<16} {:>8.2} s  {}",
                case.name,
                name,
                start.elapsed().as_secs_f64(),
                if failed == 0 {
                    "ok".to_string()
                } else {
                    format!("{failed} failed")
                }
            );
        }
        out.extend(results);
    }
    finish(out)
}

fn finish(mut out: Vec<Outcome>) -> Vec<Outcome> {
    for o in &mut out {
        if !o.passed {
            o.known_bug = known_bug_for(&o.case, &o.subject, &o.detail).map(|b| b.id.to_string());
        }
    }
    out
}

fn outcome(
    case: &Case,
    subject: &str,
    builder: Option<&str>,
    kernel: Option<&str>,
    passed: bool,
    detail: String,
    seconds: f64,
) -> Outcome {
    Outcome {
        case: case.name.clone(),
        subject: subject.to_string(),
        builder: builder.map(str::to_string),
        kernel: kernel.map(str::to_string),
        passed,
        skipped: false,
        detail,
        known_bug: None,
        seconds,
    }
}

struct Reference {
    closest: Vec<Hit>,
    any: Vec<bool>,
}

fn check_brute(case: &Case, r: &Reference) -> (bool, String) {
    let mut problems = Vec::new();
    let misses = (0..case.must_hit)
        .filter(|&i| !r.closest[i].is_hit() || !r.any[i])
        .collect::<Vec<_>>();
    if let Some(&i) = misses.first() {
        problems.push(format!(
            "{} of {} rays from inside missed (first: ray {i} {})",
            misses.len(),
            case.must_hit,
            describe_ray(&case.rays[i])
        ));
    }
    let inconsistent = (0..case.rays.len())
        .filter(|&i| r.closest[i].is_hit() != r.any[i])
        .count();
    if inconsistent > 0 {
        problems.push(format!(
            "any-hit and closest-hit disagree on {inconsistent} rays"
        ));
    }
    let invalid_hits = (0..case.rays.len())
        .filter(|&i| !case.rays[i].is_valid() && (r.closest[i].is_hit() || r.any[i]))
        .count();
    if invalid_hits > 0 {
        problems.push(format!("{invalid_hits} invalid rays hit"));
    }
    let nan = r
        .closest
        .iter()
        .filter(|h| h.is_hit() && !(h.t.is_finite()))
        .count();
    if nan > 0 {
        problems.push(format!("{nan} hits at a non-finite distance"));
    }
    if problems.is_empty() {
        let hits = r.closest.iter().filter(|h| h.is_hit()).count();
        let invalid = case.rays.iter().filter(|r| !r.is_valid()).count();
        (
            true,
            format!(
                "ok: {hits}/{} rays hit, {invalid} invalid rays",
                case.rays.len()
            ),
        )
    } else {
        (false, problems.join("; "))
    }
}

fn describe_ray(r: &Ray) -> String {
    format!(
        "o=({:e},{:e},{:e}) d=({:e},{:e},{:e}) t=[{:e},{:e}]",
        r.origin.x,
        r.origin.y,
        r.origin.z,
        r.direction().x,
        r.direction().y,
        r.direction().z,
        r.tmin,
        r.tmax
    )
}

fn describe_hit(h: &Hit) -> String {
    if h.is_hit() {
        format!("t={:e} prim={} u={:e} v={:e}", h.t, h.prim, h.u, h.v)
    } else {
        format!("miss (t={:e})", h.t)
    }
}

/// Bit-identical hits (so `-0.0` and `0.0`, or two NaNs, are told apart or matched exactly).
fn same_hit(a: &Hit, b: &Hit) -> bool {
    a.prim == b.prim
        && a.t.to_bits() == b.t.to_bits()
        && a.u.to_bits() == b.u.to_bits()
        && a.v.to_bits() == b.v.to_bits()
}

/// Everything one builder does on one case, run in its own thread.
struct Job {
    case_name: String,
    category: Category,
    builder: String,
    make: fn() -> Box<dyn Builder>,
    tris: Arc<Vec<Triangle>>,
    rays: Arc<Vec<Ray>>,
    reference: Arc<Reference>,
    must_hit: usize,
    determinism: bool,
    kernels: Vec<Kernel>,
    stage: Arc<Mutex<String>>,
}

impl Job {
    fn set_stage(&self, s: &str) {
        if let Ok(mut g) = self.stage.lock() {
            *g = s.to_string();
        }
    }

    fn outcome(&self, kernel: Option<Kernel>, passed: bool, detail: String, secs: f64) -> Outcome {
        let kname = kernel.map(|k| k.name());
        let subject = match &kname {
            Some(k) => format!("{}/{k}", self.builder),
            None => self.builder.clone(),
        };
        Outcome {
            case: self.case_name.clone(),
            subject,
            builder: Some(self.builder.clone()),
            kernel: kname,
            passed,
            skipped: false,
            detail,
            known_bug: None,
            seconds: secs,
        }
    }

    /// Builds on a pool of `threads` threads: the tree, or a typed error, or the panic.
    fn build(&self, threads: usize) -> Result<Result<Bvh, BuildError>, String> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(move |i| format!("hardcases-build-{threads}-{i}"))
            .build()
            .map_err(|e| format!("cannot create a thread pool: {e}"))?;
        let make = self.make;
        let tris = &self.tris;
        pool.install(|| {
            catch_quiet(|| {
                let input = BuildInput::new(tris, CostModel::default())?;
                make().build(&input)
            })
        })
    }

    fn run(self) -> Vec<Outcome> {
        let mut out = Vec::new();
        self.set_stage("build on 2 threads");
        let start = Instant::now();
        let built = self.build(2);
        let secs = start.elapsed().as_secs_f64();
        let bvh = match built {
            Err(p) => {
                out.push(self.outcome(None, false, p, secs));
                return out;
            }
            Ok(Err(e)) => {
                let acceptable = matches!(self.category, Category::BadGeometry | Category::Huge);
                let detail = if acceptable {
                    format!("ok: typed error: {e}")
                } else {
                    format!("unexpected build error: {e}")
                };
                out.push(self.outcome(None, acceptable, detail, secs));
                return out;
            }
            Ok(Ok(bvh)) => bvh,
        };
        let mut problems = Vec::new();
        self.set_stage("validate");
        let valid = match catch_quiet(|| bvh.validate(&self.tris)) {
            Ok(Ok(())) => true,
            Ok(Err(e)) => {
                problems.push(format!("invalid tree: {e}"));
                false
            }
            Err(p) => {
                problems.push(format!("validate panicked: {p}"));
                false
            }
        };
        self.set_stage("sah");
        let cost = catch_quiet(|| sahara_metrics::sah(&bvh, &CostModel::default()));
        match &cost {
            Ok(c) if c.is_finite() && *c >= 0.0 => {}
            Ok(c) => problems.push(format!("SAH cost is {c}")),
            Err(p) => problems.push(format!("sah panicked: {p}")),
        }
        self.set_stage("file round trip");
        let mut bytes = Vec::new();
        match catch_quiet(|| {
            bvh.save(&mut bytes)
                .map_err(|e| e.to_string())
                .and_then(|_| Bvh::load(&mut bytes.as_slice()).map_err(|e| e.to_string()))
        }) {
            Ok(Ok(loaded)) if loaded == bvh => {}
            Ok(Ok(_)) => problems.push("file round trip changed the tree".to_string()),
            Ok(Err(e)) if valid => problems.push(format!("file round trip failed: {e}")),
            Ok(Err(_)) => {}
            Err(p) => problems.push(format!("file round trip panicked: {p}")),
        }
        if self.determinism {
            for (label, threads) in [("1 thread", 1), ("2 threads again", 2)] {
                self.set_stage(&format!("rebuild on {label}"));
                let again = self.build(threads);
                match again {
                    Ok(Ok(b)) => {
                        let mut other = Vec::new();
                        let _ = b.save(&mut other);
                        if other != bytes {
                            problems.push(format!(
                                "not deterministic: the tree built on {label} differs{}",
                                first_difference(&bvh, &b)
                            ));
                        }
                    }
                    Ok(Err(e)) => problems.push(format!("rebuild on {label} failed: {e}")),
                    Err(p) => problems.push(format!("rebuild on {label} panicked: {p}")),
                }
            }
        }
        let stats = bvh.nodes.len();
        let detail = if problems.is_empty() {
            format!(
                "ok: {} nodes, SAH {:.4}",
                stats,
                cost.as_ref().copied().unwrap_or(f64::NAN)
            )
        } else {
            problems.join("; ")
        };
        out.push(self.outcome(None, problems.is_empty(), detail, secs));
        if !valid {
            return out;
        }

        // Kernels.
        let mut wide4: Option<Result<WideBvh<4>, String>> = None;
        let mut wide8: Option<Result<WideBvh<8>, String>> = None;
        for &k in &self.kernels {
            self.set_stage(&format!("kernel {k}"));
            let start = Instant::now();
            let traced: Result<(Vec<Hit>, Vec<bool>), String> = match k {
                Kernel::Bvh2 => catch_quiet(|| {
                    let c = self
                        .rays
                        .par_iter()
                        .map(|r| scalar::closest_hit(&bvh, &self.tris, r, &mut NoStats))
                        .collect();
                    let a = self
                        .rays
                        .par_iter()
                        .map(|r| scalar::any_hit(&bvh, &self.tris, r, &mut NoStats))
                        .collect();
                    (c, a)
                }),
                Kernel::Bvh4(b) => {
                    let w = wide4.get_or_insert_with(|| {
                        catch_quiet(|| WideBvh::<4>::from_bvh(&bvh, &self.tris))
                            .map_err(|p| format!("collapse to bvh4 panicked: {p}"))
                    });
                    trace_wide(w, b, &self.rays)
                }
                Kernel::Bvh8(b) => {
                    let w = wide8.get_or_insert_with(|| {
                        catch_quiet(|| WideBvh::<8>::from_bvh(&bvh, &self.tris))
                            .map_err(|p| format!("collapse to bvh8 panicked: {p}"))
                    });
                    trace_wide(w, b, &self.rays)
                }
            };
            let secs = start.elapsed().as_secs_f64();
            let o = match traced {
                Err(p) => self.outcome(Some(k), false, p, secs),
                Ok((closest, any)) => {
                    let (ok, detail) = self.compare(&closest, &any);
                    self.outcome(Some(k), ok, detail, secs)
                }
            };
            out.push(o);
        }
        self.set_stage("done");
        out
    }

    fn compare(&self, closest: &[Hit], any: &[bool]) -> (bool, String) {
        let r = &self.reference;
        let mut problems = Vec::new();
        let diff: Vec<usize> = (0..closest.len())
            .filter(|&i| !same_hit(&closest[i], &r.closest[i]))
            .collect();
        if let Some(&i) = diff.first() {
            problems.push(format!(
                "{}/{} closest hits differ from brute force (first: ray {i} {}: got {}, expected {})",
                diff.len(),
                closest.len(),
                describe_ray(&self.rays[i]),
                describe_hit(&closest[i]),
                describe_hit(&r.closest[i])
            ));
        }
        let diff_any: Vec<usize> = (0..any.len()).filter(|&i| any[i] != r.any[i]).collect();
        if let Some(&i) = diff_any.first() {
            problems.push(format!(
                "{}/{} any-hits differ (first: ray {i} {}: got {}, expected {})",
                diff_any.len(),
                any.len(),
                describe_ray(&self.rays[i]),
                any[i],
                r.any[i]
            ));
        }
        let misses = (0..self.must_hit)
            .filter(|&i| !closest[i].is_hit() || !any[i])
            .count();
        if misses > 0 {
            problems.push(format!(
                "watertightness: {misses} of {} rays from inside missed",
                self.must_hit
            ));
        }
        let invalid_hits = (0..closest.len())
            .filter(|&i| !self.rays[i].is_valid() && (closest[i].is_hit() || any[i]))
            .count();
        if invalid_hits > 0 {
            problems.push(format!("{invalid_hits} invalid rays hit"));
        }
        if problems.is_empty() {
            (true, "ok".to_string())
        } else {
            (false, problems.join("; "))
        }
    }
}

fn trace_wide<const W: usize>(
    w: &Result<WideBvh<W>, String>,
    backend: Backend,
    rays: &[Ray],
) -> Result<(Vec<Hit>, Vec<bool>), String> {
    let w = w.as_ref().map_err(|e| e.clone())?;
    catch_quiet(|| {
        let c = rays
            .par_iter()
            .map(|r| w.closest_hit_with(backend, r, &mut NoStats))
            .collect();
        let a = rays
            .par_iter()
            .map(|r| w.any_hit_with(backend, r, &mut NoStats))
            .collect();
        (c, a)
    })
}

fn first_difference(a: &Bvh, b: &Bvh) -> String {
    if a.nodes.len() != b.nodes.len() {
        return format!(" ({} vs {} nodes)", a.nodes.len(), b.nodes.len());
    }
    if let Some(i) = (0..a.nodes.len()).find(|&i| bytemuck_node(a, i) != bytemuck_node(b, i)) {
        return format!(" (first at node {i})");
    }
    if let Some(i) = (0..a.prim_indices.len()).find(|&i| a.prim_indices[i] != b.prim_indices[i]) {
        return format!(" (first at reference {i})");
    }
    String::new()
}

fn bytemuck_node(b: &Bvh, i: usize) -> [u32; 8] {
    let n = &b.nodes[i];
    [
        n.min[0].to_bits(),
        n.min[1].to_bits(),
        n.min[2].to_bits(),
        n.index,
        n.max[0].to_bits(),
        n.max[1].to_bits(),
        n.max[2].to_bits(),
        n.count,
    ]
}
