//! Images: shaded renders and heat maps of work per pixel, written as PNG.

use crate::{batch::work_total, TraceError};
use image::{codecs::png::PngEncoder, ExtendedColorType, ImageEncoder};
use sahara_geom::{Ray, Triangle};
use sahara_traverse::{Hit, WorkCounters};
use std::io::BufWriter;
use std::path::Path;

/// An 8-bit sRGB image, row-major from the top-left corner, 3 bytes per pixel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` bytes: R, G, B of pixel `py * width + px` at `3 * index`.
    pub data: Vec<u8>,
}

impl RgbImage {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            data: vec![0; width as usize * height as usize * 3],
        }
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The colour of the pixel of index `i` (`py * width + px`), `None` outside the image.
    pub fn get(&self, i: usize) -> Option<[u8; 3]> {
        let p = self.data.get(3 * i..3 * i + 3)?;
        Some([p[0], p[1], p[2]])
    }

    /// Sets the pixel of index `i`; ignored outside the image.
    pub fn set(&mut self, i: usize, rgb: [u8; 3]) {
        if let Some(p) = self.data.get_mut(3 * i..3 * i + 3) {
            p.copy_from_slice(&rgb);
        }
    }

    /// Writes the image as a PNG file (whatever the extension of `path`).
    ///
    /// # Errors
    ///
    /// [`TraceError::Io`] when the file cannot be created, [`TraceError::Image`] when encoding
    /// or writing fails (for example for a width or height of 0).
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<(), TraceError> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|source| TraceError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let image_err = |source| TraceError::Image {
            path: path.to_path_buf(),
            source,
        };
        PngEncoder::new(BufWriter::new(file))
            .write_image(&self.data, self.width, self.height, ExtendedColorType::Rgb8)
            .map_err(image_err)
    }
}

/// How [`shade`] colours surfaces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Shading {
    /// Light grey surfaces.
    Grey,
    /// A colour per primitive, from a hash of its index (shows the triangles).
    #[default]
    PrimitiveColours,
}

/// Colour of pixels whose ray missed: dark blue.
pub const MISS_COLOUR: [u8; 3] = [16, 24, 56];

/// Linear `[0, 1]` to 8-bit with a 1/2.2 gamma.
#[inline]
fn to_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0 + 0.5) as u8
}

/// A pastel colour per primitive index (each channel in `[0.35, 1]`).
fn prim_colour(prim: u32) -> [f32; 3] {
    let mut h = u64::from(prim).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    h ^= h >> 29;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 32;
    let c = |s: u32| 0.35 + 0.65 * ((h >> s) & 0xFF) as f32 / 255.0;
    [c(0), c(8), c(16)]
}

/// A shaded render: each hit pixel gets `base * (0.15 + 0.85 |dot(n, d)|)` with `n` the unit
/// geometric normal of the triangle hit and `d` the unit ray direction, `base` grey or a
/// colour per primitive ([`Shading`]); misses are [`MISS_COLOUR`], pixels without a ray black.
///
/// `pixel[i]`, `rays[i]` and `hits[i]` describe ray `i` (as in a [`crate::RaySet`] and its
/// [`crate::trace_closest`] results); extra elements of the longer slices are ignored, as are
/// pixel indices outside the image and hits on primitives outside `tris`. When several rays
/// share a pixel, the last one wins.
pub fn shade(
    width: u32,
    height: u32,
    pixel: &[u32],
    rays: &[Ray],
    hits: &[Hit],
    tris: &[Triangle],
    shading: Shading,
) -> RgbImage {
    let mut img = RgbImage::new(width, height);
    for ((&p, ray), hit) in pixel.iter().zip(rays).zip(hits) {
        let rgb = match (hit.is_hit(), tris.get(hit.prim as usize)) {
            (true, Some(tri)) => {
                let cos = tri.normal().dot(ray.direction().normalize_or_zero()).abs();
                let k = 0.15 + 0.85 * cos;
                let base = match shading {
                    Shading::Grey => [0.8; 3],
                    Shading::PrimitiveColours => prim_colour(hit.prim),
                };
                base.map(|b| to_u8(b * k))
            }
            _ => MISS_COLOUR,
        };
        img.set(p as usize, rgb);
    }
    img
}

/// Samples of matplotlib's viridis at 0, 1/8, …, 1 (perceptually uniform, readable in grey
/// and by colour-blind readers).
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 82, 139],
    [44, 114, 142],
    [33, 145, 140],
    [40, 174, 128],
    [94, 201, 98],
    [173, 220, 48],
    [253, 231, 37],
];

/// The heat-map colour of `x` in `[0, 1]` (clamped; NaN counts as 0): viridis, from dark purple
/// (no work) to yellow (the scale maximum and above), linearly interpolated between 9 samples.
pub fn colour_ramp(x: f32) -> [u8; 3] {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let s = x * (VIRIDIS.len() - 1) as f32;
    let i = (s as usize).min(VIRIDIS.len() - 2);
    let f = s - i as f32;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    std::array::from_fn(|c| (a[c] as f32 + (b[c] as f32 - a[c] as f32) * f + 0.5) as u8)
}

/// A heat map and the work that its brightest colour stands for.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatMap {
    /// The image.
    pub image: RgbImage,
    /// The work (`inner + leaves + triangles` per pixel) mapped to the top of the ramp; pixels
    /// with more work saturate. Write it next to the image (legend, report).
    pub scale_max: f64,
    /// The largest work of any pixel.
    pub max: u64,
    /// The percentile `scale_max` was taken at.
    pub percentile: f64,
}

/// A heat map of work per pixel: for each pixel, the sum over its rays of
/// `inner + leaves + triangles` ([`crate::work_total`]), divided by `scale_max` and coloured by
/// [`colour_ramp`].
///
/// `scale_max` is the `percentile`-th percentile (nearest rank; e.g. 99.0, clamped to
/// `[0, 100]`) of the work of the pixels that have at least one ray, so that a few outliers do
/// not wash the image out; it is at least 1. Pixels without a ray are black.
///
/// `pixel[i]` and `work[i]` describe ray `i` (as in a [`crate::RaySet`] and its
/// [`crate::trace_closest_counted`] work); extra elements of the longer slice and pixel indices
/// outside the image are ignored.
///
/// To compare several trees on one colour scale, build the [`PixelWork`] of each, take the
/// largest [`PixelWork::percentile`] and call [`PixelWork::heat_map`] with it.
pub fn heat_map(
    width: u32,
    height: u32,
    pixel: &[u32],
    work: &[WorkCounters],
    percentile: f64,
) -> HeatMap {
    let pw = PixelWork::new(width, height, pixel, work);
    let scale = pw.percentile(percentile);
    pw.heat_map(scale, percentile)
}

/// Work summed per pixel (`None` for pixels without a ray): the data of a heat map before a
/// colour scale is chosen.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelWork {
    width: u32,
    height: u32,
    per_pixel: Vec<Option<u64>>,
}

impl PixelWork {
    /// Sums `work_total(work[i])` into `pixel[i]` (see [`heat_map`] for the conventions).
    pub fn new(width: u32, height: u32, pixel: &[u32], work: &[WorkCounters]) -> Self {
        let n = width as usize * height as usize;
        let mut per_pixel: Vec<Option<u64>> = vec![None; n];
        for (&p, w) in pixel.iter().zip(work) {
            if let Some(slot) = per_pixel.get_mut(p as usize) {
                *slot = Some(slot.unwrap_or(0) + work_total(w));
            }
        }
        Self {
            width,
            height,
            per_pixel,
        }
    }

    /// The largest work of any pixel (0 without rays).
    pub fn max(&self) -> u64 {
        self.per_pixel.iter().flatten().copied().max().unwrap_or(0)
    }

    /// The `percentile`-th percentile (nearest rank, clamped to `[0, 100]`, NaN as 100) of the
    /// work of pixels with a ray; at least 1.
    pub fn percentile(&self, percentile: f64) -> f64 {
        let mut values: Vec<u64> = self.per_pixel.iter().flatten().copied().collect();
        if values.is_empty() {
            return 1.0;
        }
        values.sort_unstable();
        let pct = clamp_percentile(percentile);
        let rank = ((pct / 100.0) * values.len() as f64).ceil() as usize;
        (values[rank.clamp(1, values.len()) - 1] as f64).max(1.0)
    }

    /// The heat map with `scale_max` (at least 1) at the top of the ramp; `percentile` is only
    /// recorded in the result (the percentile the scale was taken at).
    pub fn heat_map(&self, scale_max: f64, percentile: f64) -> HeatMap {
        let scale_max = if scale_max.is_finite() {
            scale_max.max(1.0)
        } else {
            1.0
        };
        let mut image = RgbImage::new(self.width, self.height);
        for (i, v) in self.per_pixel.iter().enumerate() {
            if let Some(v) = v {
                image.set(i, colour_ramp((*v as f64 / scale_max) as f32));
            }
        }
        HeatMap {
            image,
            scale_max,
            max: self.max(),
            percentile: clamp_percentile(percentile),
        }
    }
}

fn clamp_percentile(p: f64) -> f64 {
    if p.is_nan() {
        100.0
    } else {
        p.clamp(0.0, 100.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sahara_geom::Vec3A;

    #[test]
    fn ramp_ends_and_monotone_brightness() {
        assert_eq!(colour_ramp(0.0), VIRIDIS[0]);
        assert_eq!(colour_ramp(1.0), VIRIDIS[8]);
        assert_eq!(colour_ramp(7.0), VIRIDIS[8]);
        assert_eq!(colour_ramp(f32::NAN), VIRIDIS[0]);
        let lum = |c: [u8; 3]| 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = lum(colour_ramp(i as f32 / 100.0));
            assert!(l >= last - 0.5, "ramp not monotone at {i}");
            last = l;
        }
    }

    #[test]
    fn heat_map_percentile_ignores_outliers_and_empty_pixels() {
        // 100 pixels with work 10, one with 10^6, one pixel without a ray.
        let (w, h) = (102, 1);
        let pixel: Vec<u32> = (0..101).collect();
        let mut work = vec![
            WorkCounters {
                inner: 5,
                leaves: 1,
                triangles: 4
            };
            101
        ];
        work[7].triangles = 1_000_000;
        let hm = heat_map(w, h, &pixel, &work, 99.0);
        assert_eq!(hm.scale_max, 10.0);
        assert_eq!(hm.max, 1_000_006);
        assert_eq!(hm.image.get(0), Some(VIRIDIS[8]));
        assert_eq!(hm.image.get(7), Some(VIRIDIS[8]));
        assert_eq!(hm.image.get(101), Some([0, 0, 0]));
        let hm = heat_map(w, h, &pixel, &work, 100.0);
        assert_eq!(hm.scale_max, 1_000_006.0);
        assert_eq!(hm.image.get(7), Some(VIRIDIS[8]));
        assert_eq!(heat_map(0, 0, &[], &[], 99.0).scale_max, 1.0);
    }

    #[test]
    fn shading_facing_and_misses() {
        let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        let ray = Ray::new(Vec3A::new(0.2, 0.2, 1.0), Vec3A::NEG_Z, 0.0, f32::INFINITY);
        let hit = Hit {
            t: 1.0,
            prim: 0,
            u: 0.2,
            v: 0.2,
        };
        let img = shade(
            3,
            1,
            &[0, 1],
            &[ray, ray],
            &[hit, Hit::MISS],
            &[tri],
            Shading::Grey,
        );
        assert_eq!(img.get(0), Some([to_u8(0.8); 3]));
        assert_eq!(img.get(1), Some(MISS_COLOUR));
        assert_eq!(img.get(2), Some([0, 0, 0]));
        assert_eq!(img.get(3), None);
    }

    #[test]
    fn shared_scale_makes_heat_maps_comparable() {
        let pixel = [0u32, 1, 1];
        let light = [WorkCounters::default(); 3];
        let mut heavy = [WorkCounters::default(); 3];
        for w in &mut heavy {
            w.inner = 10;
        }
        let a = PixelWork::new(2, 1, &pixel, &light);
        let b = PixelWork::new(2, 1, &pixel, &heavy);
        assert_eq!(b.max(), 20);
        let scale = a.percentile(100.0).max(b.percentile(100.0));
        assert_eq!(scale, 20.0);
        let (ha, hb) = (a.heat_map(scale, 100.0), b.heat_map(scale, 100.0));
        // The same work gets the same colour in both images; more work is brighter.
        assert_eq!(hb.image.get(1), Some(colour_ramp(1.0)));
        assert_eq!(hb.image.get(0), Some(colour_ramp(0.5)));
        assert_eq!(ha.image.get(0), Some(colour_ramp(0.0)));
        assert_eq!(ha.scale_max, hb.scale_max);
    }
}
