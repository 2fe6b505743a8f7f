use sahara_geom::intersect::intersect_triangle;
use sahara_geom::{Ray, Vec3A};
use sahara_scene::{Catalog, Scene};
use std::io::Write;

fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in data {
        c ^= b as u32;
        for _ in 0..8 { c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 }; }
    }
    !c
}
fn png(path: &str, w: u32, h: u32, px: &[u8]) {
    let mut raw = Vec::new();
    for y in 0..h as usize { raw.push(0u8); raw.extend_from_slice(&px[y * w as usize..(y + 1) * w as usize]); }
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(&raw).unwrap();
    let idat = z.finish().unwrap();
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |ty: &[u8], d: &[u8]| {
        out.extend_from_slice(&(d.len() as u32).to_be_bytes());
        let mut c = ty.to_vec(); c.extend_from_slice(d);
        out.extend_from_slice(&c);
        out.extend_from_slice(&crc32(&c).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes()); ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    chunk(b"IHDR", &ihdr); chunk(b"IDAT", &idat); chunk(b"IEND", &[]);
    std::fs::write(path, out).unwrap();
}
fn render(s: &Scene, w: u32, h: u32) {
    let tris = s.triangles();
    let c = s.camera;
    let f = c.direction();
    let r = f.cross(c.up).normalize();
    let u = r.cross(f);
    let t = (c.fov_y_degrees.to_radians() * 0.5).tan();
    let mut px = vec![0u8; (w * h) as usize];
    for j in 0..h { for i in 0..w {
        let x = (2.0 * (i as f32 + 0.5) / w as f32 - 1.0) * t * w as f32 / h as f32;
        let y = (1.0 - 2.0 * (j as f32 + 0.5) / h as f32) * t;
        let d: Vec3A = (f + r * x + u * y).normalize();
        let ray = Ray::new(c.eye, d, 0.0, f32::INFINITY);
        let wr = ray.watertight();
        let mut best = f32::INFINITY; let mut shade = 0.0;
        for tr in &tris {
            if let Some(hit) = intersect_triangle(&wr, tr, 0.0, best) {
                if hit.t < best { best = hit.t; shade = tr.normal().dot(d).abs(); }
            }
        }
        px[(j * w + i) as usize] = if best.is_finite() { (40.0 + 215.0 * shade) as u8 } else { 0 };
    }}
    png(&format!("/tmp/renders/{}.png", s.name.replace(':', "_")), w, h, &px);
}
#[test]
fn scratch_render() {
    let c = Catalog::discover();
    for n in ["teapot_stadium", "city", "san_francisco_osm", "sponza_dabrovic"] {
        if n.ends_with(":skip") { continue; }
        let s = c.load(n).unwrap();
        if s.triangle_count() > 100_000 { render(&s, 80, 60) } else { render(&s, 160, 120) };
    }
}
