//! Intel Embree 3 as a [`Tracer`], for a side-by-side row next to sahara's own layouts.
//!
//! Only compiled with the cargo feature `embree` (off by default; it links Debian's
//! `libembree-dev`, 3.13, through the `embree` binding crate, whose build script emits
//! `-l embree3`). See docs/embree.md:
//!
//! ```text
//! cargo run --release -p xtask --features embree -- trace --scene sibenik --builder sweep \
//!     --engine embree --rays diffuse --threads 1
//! ```
//!
//! Embree builds its own BVH from the triangles (the builder's tree is ignored): a scene of
//! quality MEDIUM, scene flags NONE (Embree's fast, non-robust mode), one triangle geometry
//! whose primitive ids are the indices of the caller's triangle slice. Queries use the
//! single-ray API (`rtcIntersect1` for closest hits, `rtcOccluded1` for any hit) with an
//! incoherent intersect context, the protocol of the reference figures in `docs/baselines.md`.
//!
//! Two environment variables change the scene, for experiments only (the report's layout
//! name stays `embree`): `SAHARA_EMBREE_QUALITY=low|medium|high` and
//! `SAHARA_EMBREE_ROBUST=1` (`RTC_SCENE_FLAG_ROBUST`). `SAHARA_EMBREE_CONFIG` is passed to
//! `rtcNewDevice` (e.g. `verbose=1`, which prints the ISA to stdout), after the `isa=` that
//! matches sahara's `--backend` ([`matching_isa`]: `sse2`, `avx2`, `avx512`; none for
//! `portable`), so that an `isa=` of the user's wins.
//!
//! Departures from the [`Tracer`] contract, inherent to Embree:
//!
//! * Embree's triangle test is not watertight and its tie-break at equal distance is not
//!   "lowest primitive index", so a few rays may hit another triangle than sahara's kernels;
//! * Embree requires `tnear >= 0`, so a negative `tmin` is clamped to 0;
//! * the work counters stay zero (Embree does not expose them).
//!
//! Invalid rays ([`Ray::is_valid`]) miss without calling Embree (its behaviour on NaN is
//! undefined).

use crate::alloc_count::RunningPeak;
use anyhow::{bail, ensure, Context, Result};
use embree::sys;
use sahara_geom::{Ray, Triangle};
use sahara_trace::{Backend, Hit, Tracer, WorkCounters};
use std::ffi::CString;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, Weak};

/// `RTC_INVALID_GEOMETRY_ID`.
const INVALID_ID: u32 = u32::MAX;

// The binding's structs must match Debian's 3.13 headers (RTC_MAX_INSTANCE_LEVEL_COUNT 1,
// RTC_MIN_WIDTH 0): RTCRay 48 bytes, RTCHit 32, RTCRayHit 80, all aligned to 16.
const _: () = {
    assert!(std::mem::size_of::<sys::RTCRay>() == 48);
    assert!(std::mem::align_of::<sys::RTCRay>() == 16);
    assert!(std::mem::size_of::<sys::RTCHit>() == 32);
    assert!(std::mem::size_of::<sys::RTCRayHit>() == 80);
    assert!(std::mem::align_of::<sys::RTCRayHit>() == 16);
    assert!(std::mem::size_of::<sys::RTCIntersectContext>() == 24);
};

/// How the Embree scene is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Config {
    /// `RTC_BUILD_QUALITY_{LOW,MEDIUM,HIGH}` as 0, 1, 2.
    quality: u8,
    /// `RTC_SCENE_FLAG_ROBUST`.
    robust: bool,
    /// The `isa=` of the device configuration (from `--backend`), `None`: Embree's choice.
    isa: Option<&'static str>,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            quality: 1,
            robust: false,
            isa: None,
        }
    }
}

/// The Embree ISA that matches sahara's `backend` (Embree's names for the device
/// configuration's `isa=`): `sse2` for SSE2, `avx2` for AVX2, `avx512` for AVX-512; `None` for
/// the portable kernels, which Embree has no counterpart of (it then picks its own ISA).
pub fn matching_isa(backend: Backend) -> Option<&'static str> {
    match backend {
        Backend::Portable => None,
        Backend::Sse2 => Some("sse2"),
        Backend::Avx2 => Some("avx2"),
        Backend::Avx512 => Some("avx512"),
    }
}

/// The device configuration for `rtcNewDevice`: `isa=…` when given, then the user's
/// `SAHARA_EMBREE_CONFIG` (`user`), comma-separated. Embree reads the settings in order, so
/// an `isa=` of the user's comes last and wins.
pub fn device_config(isa: Option<&str>, user: &str) -> String {
    let mut parts: Vec<&str> = Vec::new();
    let own = isa.map(|i| format!("isa={i}"));
    if let Some(o) = &own {
        parts.push(o);
    }
    let user = user.trim().trim_matches(',');
    if !user.is_empty() {
        parts.push(user);
    }
    parts.join(",")
}

/// The last `isa=` of a device configuration (what Embree will run), if any.
pub fn configured_isa(config: &str) -> Option<String> {
    config.split(',').rev().find_map(|kv| {
        let (k, v) = kv.split_once('=')?;
        (k.trim() == "isa").then(|| v.trim().to_string())
    })
}

/// What the reports' `backend` field says for Embree traced with sahara's `backend`: the ISA
/// of the device configuration (`SAHARA_EMBREE_CONFIG` included), or `default` when Embree
/// picks its own (portable backend, no `isa=`).
pub fn reported_isa(backend: Backend) -> String {
    let user = std::env::var("SAHARA_EMBREE_CONFIG").unwrap_or_default();
    configured_isa(&device_config(matching_isa(backend), &user)).unwrap_or_else(|| "default".into())
}

impl Config {
    /// The default (MEDIUM, not robust), changed by `SAHARA_EMBREE_QUALITY` and
    /// `SAHARA_EMBREE_ROBUST`.
    pub fn from_env() -> Result<Self> {
        let mut c = Self::default();
        if let Ok(q) = std::env::var("SAHARA_EMBREE_QUALITY") {
            c.quality = match q.to_ascii_lowercase().as_str() {
                "low" => 0,
                "medium" | "" => 1,
                "high" => 2,
                other => bail!("SAHARA_EMBREE_QUALITY: '{other}' is not low, medium or high"),
            };
        }
        if let Ok(r) = std::env::var("SAHARA_EMBREE_ROBUST") {
            c.robust = !matches!(r.as_str(), "" | "0" | "false" | "no");
        }
        Ok(c)
    }

    fn quality(self) -> sys::RTCBuildQuality {
        match self.quality {
            0 => sys::RTCBuildQuality::LOW,
            2 => sys::RTCBuildQuality::HIGH,
            _ => sys::RTCBuildQuality::MEDIUM,
        }
    }

    fn flags(self) -> sys::RTCSceneFlags {
        if self.robust {
            sys::RTCSceneFlags::ROBUST
        } else {
            sys::RTCSceneFlags::NONE
        }
    }
}

/// An Embree device with one committed scene. Released on drop.
struct Scene {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
}

// SAFETY: a committed Embree scene may be queried from any number of threads at once
// (Embree's API documentation, "Thread safety"); it is never modified after `build`.
unsafe impl Send for Scene {}
// SAFETY: as above.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: both handles were created by `build` and are released exactly once.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}

/// The device's pending error, as a `Result`.
fn check(device: sys::RTCDevice, what: &str) -> Result<()> {
    // SAFETY: `device` is a live device handle.
    let e = unsafe { sys::rtcGetDeviceError(device) };
    ensure!(e == sys::RTCError::NONE, "Embree error {e:?} while {what}");
    Ok(())
}

impl Scene {
    /// Copies `tris` into a new Embree device and scene and commits it (builds the BVH).
    fn build(tris: &[Triangle], config: Config) -> Result<Self> {
        let n = tris.len();
        ensure!(
            n.checked_mul(3).is_some_and(|v| v <= u32::MAX as usize),
            "{n} triangles are too many for one Embree geometry"
        );
        let user = std::env::var("SAHARA_EMBREE_CONFIG").unwrap_or_default();
        let device_config = CString::new(device_config(config.isa, &user))
            .context("SAHARA_EMBREE_CONFIG contains a NUL byte")?;
        // SAFETY: a NUL-terminated configuration string.
        let device = unsafe { sys::rtcNewDevice(device_config.as_ptr()) };
        if device.is_null() {
            // SAFETY: a null device asks for the thread's last device-creation error.
            let e = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            bail!("rtcNewDevice failed ({e:?}); is libembree3 usable on this CPU?");
        }
        let mut s = Scene {
            device,
            scene: std::ptr::null_mut(),
        };
        // SAFETY: every handle below is checked for null before use; the buffers returned by
        // rtcSetNewGeometryBuffer are owned by the geometry, sized for the item counts given
        // and written in bounds; the geometry is released after being attached (the scene
        // keeps its own reference).
        unsafe {
            s.scene = sys::rtcNewScene(device);
            check(device, "creating the scene")?;
            ensure!(!s.scene.is_null(), "rtcNewScene returned null");
            if n > 0 {
                attach_triangles(device, s.scene, tris)?;
            }
            sys::rtcSetSceneBuildQuality(s.scene, config.quality());
            sys::rtcSetSceneFlags(s.scene, config.flags());
            sys::rtcCommitScene(s.scene);
            check(device, "committing the scene (building its BVH)")?;
        }
        Ok(s)
    }
}

/// Makes a triangle geometry of `tris`, commits it and attaches it to `scene`; the geometry is
/// released after being attached (the scene keeps its own reference), or when filling its
/// buffers failed.
///
/// # Safety
///
/// `device` and `scene` are live handles, `scene` made on `device`; `tris` is not empty and
/// `tris.len() * 3` fits in `u32`.
unsafe fn attach_triangles(
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    tris: &[Triangle],
) -> Result<()> {
    // SAFETY: the geometry is checked for null before use; its buffers are written in bounds
    // by `fill_buffers` (the caller's bounds on `tris`).
    unsafe {
        let geom = sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE);
        check(device, "creating the triangle geometry")?;
        ensure!(!geom.is_null(), "rtcNewGeometry returned null");
        let filled = fill_buffers(geom, tris);
        if filled.is_ok() {
            sys::rtcCommitGeometry(geom);
            sys::rtcAttachGeometry(scene, geom);
        }
        sys::rtcReleaseGeometry(geom);
        filled?;
        check(device, "committing the triangle geometry")
    }
}

/// Writes the vertex (three per triangle, FLOAT3 with a 16-byte stride) and index buffers
/// of `geom`.
///
/// # Safety
///
/// `geom` is a live triangle geometry; `tris.len() * 3` fits in `u32`.
unsafe fn fill_buffers(geom: sys::RTCGeometry, tris: &[Triangle]) -> Result<()> {
    let n = tris.len();
    // SAFETY (whole body): the caller's contract; each buffer is checked for null and holds
    // exactly the item count requested, with the stride given.
    unsafe {
        let vb = sys::rtcSetNewGeometryBuffer(
            geom,
            sys::RTCBufferType::VERTEX,
            0,
            sys::RTCFormat::FLOAT3,
            16,
            3 * n,
        ) as *mut [f32; 4];
        ensure!(!vb.is_null(), "Embree could not allocate the vertex buffer");
        let vertices = std::slice::from_raw_parts_mut(vb, 3 * n);
        for (out, t) in vertices.chunks_exact_mut(3).zip(tris) {
            for (o, p) in out.iter_mut().zip(&t.v) {
                *o = [p.x, p.y, p.z, 0.0];
            }
        }
        let ib = sys::rtcSetNewGeometryBuffer(
            geom,
            sys::RTCBufferType::INDEX,
            0,
            sys::RTCFormat::UINT3,
            12,
            n,
        ) as *mut [u32; 3];
        ensure!(!ib.is_null(), "Embree could not allocate the index buffer");
        let indices = std::slice::from_raw_parts_mut(ib, n);
        for (i, out) in indices.iter_mut().enumerate() {
            let b = 3 * i as u32;
            *out = [b, b + 1, b + 2];
        }
    }
    Ok(())
}

/// What identifies a built scene in the cache: the slice's address and length, a hash of its
/// coordinates (so that a reused address with other contents is not mistaken for it) and the
/// configuration.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Key {
    ptr: usize,
    len: usize,
    hash: u64,
    config: Config,
}

fn content_hash(tris: &[Triangle]) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for t in tris {
        for p in &t.v {
            p.to_array().map(f32::to_bits).hash(&mut h);
        }
    }
    h.finish()
}

/// Scenes alive somewhere, so that the tracers of several builders' trees over the same
/// triangles (the eval makes one per builder) share one Embree build.
static CACHE: Mutex<Vec<(Key, Weak<Scene>)>> = Mutex::new(Vec::new());

/// A tracer answering queries with Embree over its own BVH of `tris` (see the module
/// documentation). Cheap to clone; the scene is released with the last clone.
#[derive(Clone)]
pub struct EmbreeTracer {
    scene: Arc<Scene>,
}

impl EmbreeTracer {
    /// The tracer over `tris` with Embree's own choice of ISA (see [`EmbreeTracer::with_backend`]).
    #[cfg(test)]
    pub fn new(tris: &[Triangle]) -> Result<Self> {
        Self::with_isa(tris, None)
    }

    /// The tracer over `tris` with the Embree ISA matching sahara's `backend`
    /// ([`matching_isa`]); for [`Backend::Portable`], which Embree has no counterpart of, a
    /// note on stderr says that Embree runs its own choice.
    pub fn with_backend(tris: &[Triangle], backend: Backend) -> Result<Self> {
        let isa = matching_isa(backend);
        if isa.is_none() {
            static SAID: std::sync::Once = std::sync::Once::new();
            SAID.call_once(|| {
                eprintln!(
                    "note: Embree has no portable (scalar) ISA to match --backend portable; \
                     it runs the ISA it picks itself"
                )
            });
        }
        Self::with_isa(tris, isa)
    }

    /// The tracer over `tris`, building the Embree scene unless one over the same triangles
    /// with the same configuration ([`Config::from_env`] and `isa`) is still alive.
    fn with_isa(tris: &[Triangle], isa: Option<&'static str>) -> Result<Self> {
        let config = Config {
            isa,
            ..Config::from_env()?
        };
        let key = Key {
            ptr: tris.as_ptr() as usize,
            len: tris.len(),
            hash: content_hash(tris),
            config,
        };
        let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        cache.retain(|(_, w)| w.strong_count() > 0);
        if let Some(scene) = cache
            .iter()
            .find(|(k, _)| *k == key)
            .and_then(|(_, w)| w.upgrade())
        {
            return Ok(Self { scene });
        }
        let scene = Arc::new(Scene::build(tris, config)?);
        cache.push((key, Arc::downgrade(&scene)));
        Ok(Self { scene })
    }

    /// Embree's ray for `ray` (valid rays only): `tnear` clamped to 0, full mask.
    #[inline]
    fn rtc_ray(ray: &Ray) -> sys::RTCRay {
        sys::RTCRay {
            org_x: ray.origin.x,
            org_y: ray.origin.y,
            org_z: ray.origin.z,
            tnear: ray.tmin.max(0.0),
            dir_x: ray.direction().x,
            dir_y: ray.direction().y,
            dir_z: ray.direction().z,
            time: 0.0,
            tfar: ray.tmax,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// What `rtcInitIntersectContext` sets.
    #[inline]
    fn context() -> sys::RTCIntersectContext {
        sys::RTCIntersectContext {
            flags: sys::RTCIntersectContextFlags::INCOHERENT,
            filter: None,
            instID: [INVALID_ID],
        }
    }
}

impl Tracer for EmbreeTracer {
    fn name(&self) -> &str {
        "embree"
    }

    #[inline]
    fn closest_hit(&self, ray: &Ray, _stats: &mut WorkCounters) -> Hit {
        self.closest_hit_fast(ray)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray, _stats: &mut WorkCounters) -> bool {
        self.any_hit_fast(ray)
    }

    #[inline]
    fn closest_hit_fast(&self, ray: &Ray) -> Hit {
        if !ray.is_valid() {
            return Hit::MISS;
        }
        let mut rh = sys::RTCRayHit {
            ray: Self::rtc_ray(ray),
            hit: sys::RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: INVALID_ID,
                geomID: INVALID_ID,
                instID: [INVALID_ID],
            },
        };
        let mut ctx = Self::context();
        // SAFETY: a committed scene; `rh` is a 16-byte aligned RTCRayHit with finite origin
        // and direction and 0 <= tnear <= tfar.
        unsafe { sys::rtcIntersect1(self.scene.scene, &mut ctx, &mut rh) };
        if rh.hit.geomID == INVALID_ID {
            Hit::MISS
        } else {
            Hit {
                t: rh.ray.tfar,
                prim: rh.hit.primID,
                u: rh.hit.u,
                v: rh.hit.v,
            }
        }
    }

    #[inline]
    fn any_hit_fast(&self, ray: &Ray) -> bool {
        if !ray.is_valid() {
            return false;
        }
        let mut r = Self::rtc_ray(ray);
        let mut ctx = Self::context();
        // SAFETY: as in `closest_hit_fast`, with an RTCRay.
        unsafe { sys::rtcOccluded1(self.scene.scene, &mut ctx, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }
}

/// Times Embree's own BVH builds for `cargo xtask build-bench`: one device (created once, so
/// that its thread pool is up before the first timed build) and, per build, a new scene with
/// one triangle geometry, of which only `rtcCommitScene` is timed (the BVH build; Embree
/// builds its 8-wide tree directly on this machine). See docs/embree.md.
///
/// It also measures a build's memory ([`BuildTimer::measure_memory`]) through the device's
/// memory monitor callback, which is set only for that (untimed) build.
pub struct BuildTimer {
    device: sys::RTCDevice,
    /// The running sum of the monitor's byte deltas; boxed, so that its address, which the
    /// device holds while the monitor is set, stays put.
    monitor: Box<RunningPeak>,
}

// SAFETY: the device is only used by the thread that owns the timer (the type is not shared).
unsafe impl Send for BuildTimer {}

impl Drop for BuildTimer {
    fn drop(&mut self) {
        // SAFETY: created by `new`, released exactly once.
        unsafe { sys::rtcReleaseDevice(self.device) };
    }
}

/// `low|medium|high` as the build quality of [`Config`].
pub fn parse_quality(name: &str) -> Result<u8> {
    Ok(match name.to_ascii_lowercase().as_str() {
        "low" => 0,
        "medium" => 1,
        "high" => 2,
        other => bail!("Embree build quality '{other}' is not low, medium or high"),
    })
}

/// The bytes Embree's memory monitor saw during one build of [`BuildTimer::measure_memory`]:
/// every allocation Embree reports to `rtcSetDeviceMemoryMonitorFunction`, which are its
/// geometry buffers, its monitored vectors (the builders' primitive references and other
/// arrays of the build) and the blocks of its node and leaf allocator; not its small
/// temporaries on the C++ heap or the stack, nor the caller's triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmbreeMemory {
    /// Live before `rtcCommitScene`: the vertex and index buffers of the geometry (here 16
    /// bytes per vertex, three vertices and 12 bytes of indices per triangle) and whatever the
    /// geometry's commit allocated.
    pub scene_bytes: usize,
    /// The most bytes live at once during `rtcCommitScene`, above `scene_bytes`: the build's
    /// working memory and the tree it keeps.
    pub commit_peak_bytes: usize,
    /// Live after `rtcCommitScene`, above `scene_bytes`: the tree Embree keeps (nodes and
    /// leaves with their copies of the triangles).
    pub retained_bytes: usize,
    /// Live after the scene was released (0 unless Embree keeps memory past its scene).
    pub left_after_release: i64,
}

/// The device's memory monitor: adds Embree's byte delta to the [`RunningPeak`] at `ptr` and
/// lets every allocation go ahead.
unsafe extern "C" fn monitor(ptr: *mut std::ffi::c_void, bytes: sys::ssize_t, _post: bool) -> bool {
    // SAFETY: `ptr` is the timer's boxed `RunningPeak`, set with this callback by
    // `measure_memory` and unset before it returns, so it is alive whenever Embree calls.
    let m = unsafe { &*(ptr as *const RunningPeak) };
    m.record(bytes as i64);
    true
}

impl BuildTimer {
    /// A device with `threads` build threads (`threads=N` in the device configuration,
    /// followed by `SAHARA_EMBREE_CONFIG` if set).
    pub fn new(threads: usize) -> Result<Self> {
        let extra = std::env::var("SAHARA_EMBREE_CONFIG").unwrap_or_default();
        let mut config = format!("threads={}", threads.max(1));
        if !extra.is_empty() {
            config.push(',');
            config.push_str(&extra);
        }
        let config = CString::new(config).context("SAHARA_EMBREE_CONFIG contains a NUL byte")?;
        // SAFETY: a NUL-terminated configuration string.
        let device = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if device.is_null() {
            // SAFETY: a null device asks for the thread's last device-creation error.
            let e = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            bail!("rtcNewDevice failed ({e:?}); is libembree3 usable on this CPU?");
        }
        Ok(Self {
            device,
            monitor: Box::new(RunningPeak::new()),
        })
    }

    /// Builds Embree's BVH over `tris` at `quality` (0, 1, 2: LOW, MEDIUM, HIGH; scene flags
    /// NONE) and returns the seconds `rtcCommitScene` took.
    pub fn time_build(&self, tris: &[Triangle], quality: u8) -> Result<f64> {
        self.with_scene(tris, quality, |scene| {
            let t0 = std::time::Instant::now();
            // SAFETY: a live scene with its geometry attached and committed.
            unsafe { sys::rtcCommitScene(scene) };
            t0.elapsed().as_secs_f64()
        })
    }

    /// Builds Embree's BVH over `tris` at `quality`, as [`BuildTimer::time_build`] does, with
    /// the device's memory monitor summing Embree's allocations from the new scene's first
    /// to its release (see [`EmbreeMemory`]). Not for timing: the monitor is a callback per
    /// allocation.
    pub fn measure_memory(&self, tris: &[Triangle], quality: u8) -> Result<EmbreeMemory> {
        let m: &RunningPeak = &self.monitor;
        m.record(-m.live());
        m.reset_peak();
        let ptr = m as *const RunningPeak as *mut std::ffi::c_void;
        // SAFETY: a live device; `ptr` outlives the monitor's setting (unset below).
        unsafe { sys::rtcSetDeviceMemoryMonitorFunction(self.device, Some(monitor), ptr) };
        let result = self.with_scene(tris, quality, |scene| {
            let before = m.reset_peak();
            // SAFETY: a live scene with its geometry attached and committed.
            unsafe { sys::rtcCommitScene(scene) };
            (before, m.peak(), m.live())
        });
        // SAFETY: a live device; no build runs now, so Embree calls the monitor no more.
        unsafe { sys::rtcSetDeviceMemoryMonitorFunction(self.device, None, std::ptr::null_mut()) };
        let (before, peak, after) = result?;
        let bytes = |b: i64| b.max(0) as usize;
        Ok(EmbreeMemory {
            scene_bytes: bytes(before),
            commit_peak_bytes: bytes(peak - before),
            retained_bytes: bytes(after - before),
            left_after_release: m.live(),
        })
    }

    /// Creates a scene over `tris` at `quality` (scene flags NONE) with one triangle geometry,
    /// runs `commit` on it (which calls `rtcCommitScene`), checks the device for errors and
    /// releases the scene.
    fn with_scene<R>(
        &self,
        tris: &[Triangle],
        quality: u8,
        commit: impl FnOnce(sys::RTCScene) -> R,
    ) -> Result<R> {
        let n = tris.len();
        ensure!(
            n > 0 && n.checked_mul(3).is_some_and(|v| v <= u32::MAX as usize),
            "{n} triangles: not a scene Embree can time"
        );
        let device = self.device;
        let config = Config {
            quality,
            robust: false,
            isa: None,
        };
        // SAFETY: as in `Scene::build`: handles checked for null, buffers written in bounds by
        // `fill_buffers`, the geometry released after being attached, the scene released
        // before returning.
        unsafe {
            let scene = sys::rtcNewScene(device);
            check(device, "creating the scene")?;
            ensure!(!scene.is_null(), "rtcNewScene returned null");
            let result = (|| {
                attach_triangles(device, scene, tris)?;
                sys::rtcSetSceneBuildQuality(scene, config.quality());
                sys::rtcSetSceneFlags(scene, config.flags());
                let r = commit(scene);
                check(device, "committing the scene (building its BVH)")?;
                Ok(r)
            })();
            sys::rtcReleaseScene(scene);
            result
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::Vec3A;

    fn quad() -> Vec<Triangle> {
        let p = |x: f32, y: f32| Vec3A::new(x, y, 0.0);
        vec![
            Triangle::new(p(0.0, 0.0), p(1.0, 0.0), p(0.0, 1.0)),
            Triangle::new(p(1.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)),
        ]
    }

    #[test]
    fn hits_misses_and_invalid_rays() {
        let tris = quad();
        let t = EmbreeTracer::new(&tris).unwrap();
        let down = Vec3A::new(0.0, 0.0, -1.0);
        let r = Ray::new(Vec3A::new(0.25, 0.25, 2.0), down, 0.0, f32::INFINITY);
        let h = t.closest_hit_fast(&r);
        assert_eq!(h.prim, 0);
        assert!((h.t - 2.0).abs() < 1e-5);
        assert!((h.u - 0.25).abs() < 1e-5 && (h.v - 0.25).abs() < 1e-5);
        assert!(t.any_hit_fast(&r));
        let r = Ray::new(Vec3A::new(0.75, 0.75, 2.0), down, 0.0, f32::INFINITY);
        assert_eq!(t.closest_hit_fast(&r).prim, 1);
        let miss = Ray::new(Vec3A::new(2.0, 2.0, 2.0), down, 0.0, f32::INFINITY);
        assert_eq!(t.closest_hit_fast(&miss), Hit::MISS);
        assert!(!t.any_hit_fast(&miss));
        let short = Ray::new(Vec3A::new(0.25, 0.25, 2.0), down, 0.0, 1.0);
        assert!(!t.any_hit_fast(&short));
        let nan = Ray::new(Vec3A::new(f32::NAN, 0.0, 2.0), down, 0.0, f32::INFINITY);
        assert_eq!(t.closest_hit_fast(&nan), Hit::MISS);
        assert!(!t.any_hit_fast(&nan));
        // A second tracer over the same slice shares the scene.
        let t2 = EmbreeTracer::new(&tris).unwrap();
        assert!(Arc::ptr_eq(&t.scene, &t2.scene));
    }

    #[test]
    fn device_configuration_matches_the_backend() {
        assert_eq!(matching_isa(Backend::Sse2), Some("sse2"));
        assert_eq!(matching_isa(Backend::Avx2), Some("avx2"));
        assert_eq!(matching_isa(Backend::Avx512), Some("avx512"));
        assert_eq!(matching_isa(Backend::Portable), None);
        assert_eq!(device_config(Some("avx2"), ""), "isa=avx2");
        assert_eq!(
            device_config(Some("sse2"), "verbose=1,"),
            "isa=sse2,verbose=1"
        );
        assert_eq!(device_config(None, "verbose=2"), "verbose=2");
        assert_eq!(device_config(None, ""), "");
        // The user's isa comes last, so it is the one Embree runs and reports say.
        let c = device_config(Some("avx2"), "isa=sse4.2");
        assert_eq!(configured_isa(&c).as_deref(), Some("sse4.2"));
        assert_eq!(configured_isa("verbose=1"), None);
    }

    #[test]
    fn every_available_isa_gives_the_same_hits_on_a_quad() {
        let tris = quad();
        let down = Vec3A::new(0.0, 0.0, -1.0);
        for b in Backend::ALL.into_iter().filter(|b| b.is_available()) {
            let t = EmbreeTracer::with_backend(&tris, b).unwrap();
            let r = Ray::new(Vec3A::new(0.75, 0.75, 2.0), down, 0.0, f32::INFINITY);
            assert_eq!(t.closest_hit_fast(&r).prim, 1, "{b}");
        }
    }

    #[test]
    fn the_memory_monitor_sees_a_build() {
        let tris = sahara_scene::soup(2000, 1).triangles();
        let timer = BuildTimer::new(1).unwrap();
        for quality in 0..3 {
            let m = timer.measure_memory(&tris, quality).unwrap();
            // The buffers: 16 bytes per vertex, three vertices and 12 bytes of indices per
            // triangle.
            assert!(m.scene_bytes >= 60 * tris.len(), "{quality}: {m:?}");
            assert!(m.retained_bytes > 0, "{quality}: {m:?}");
            assert!(m.commit_peak_bytes >= m.retained_bytes, "{quality}: {m:?}");
            assert_eq!(m.left_after_release, 0, "{quality}: {m:?}");
        }
        // The monitor is unset after the measurement: a timed build adds nothing.
        timer.monitor.reset_peak();
        timer.time_build(&tris, 1).unwrap();
        assert_eq!((timer.monitor.live(), timer.monitor.peak()), (0, 0));
    }

    #[test]
    fn empty_scene_misses() {
        let t = EmbreeTracer::new(&[]).unwrap();
        let r = Ray::new(Vec3A::ZERO, Vec3A::X, 0.0, f32::INFINITY);
        assert_eq!(t.closest_hit_fast(&r), Hit::MISS);
    }
}
