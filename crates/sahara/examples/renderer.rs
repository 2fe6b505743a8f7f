//! A small renderer over the façade, as ASCII art: everything a real-time renderer asks of a
//! ray tracer, each answer checked against brute force.
//!
//! * a [`Scene`] of static geometry, shaded by **geometry id**: a floor, a glass pane whose
//!   **mask** lets camera rays see it but shadow rays through, and a fence whose triangles are
//!   cut into a lattice by an **any-hit filter** (an alpha test on the barycentrics);
//! * a **moving instance**: a spinner (one mesh in an [`Instances`] set) that orbits and turns,
//!   one `set_transform` per frame;
//! * a flag built at [`Quality::High`] (spatial splits) and **refitted** every frame to its
//!   waving triangles ([`Accel::refit`]: the clipped boxes are clipped again, see
//!   `docs/refit.md`).
//!
//! Every pixel's camera ray and shadow ray are traced through the three structures and checked
//! against their brute-force twins; each frame prints its image and a line of counts and a
//! checksum (the same on every machine and backend).
//!
//! ```sh
//! cargo run --release -p sahara --example renderer
//! ```
//!
//! `cargo test -p sahara --example renderer` runs the same frames as a test.

use sahara::sahara_traverse::brute;
use sahara::{
    Accel, Affine3A, GeometryId, Instances, Quality, Ray, Scene, SceneBuilder, SceneHit, Triangle,
    Vec3, Vec3A,
};

/// Ray masks: camera rays and shadow rays.
const CAMERA: u32 = 1;
const SHADOW: u32 = 2;
const WIDTH: usize = 64;
const HEIGHT: usize = 22;

/// A quad as two triangles.
fn quad(a: Vec3A, b: Vec3A, c: Vec3A, d: Vec3A) -> [Triangle; 2] {
    [Triangle::new(a, b, c), Triangle::new(a, c, d)]
}

/// The static scene: its structure and the ids of the floor, the glass and the fence.
fn static_scene() -> Result<(Scene, [GeometryId; 3]), sahara::Error> {
    let v = Vec3A::new;
    let mut b = SceneBuilder::new();
    let floor = b.add_triangles(&quad(
        v(-8.0, -1.0, 2.0),
        v(8.0, -1.0, 2.0),
        v(8.0, -1.0, 16.0),
        v(-8.0, -1.0, 16.0),
    ));
    let glass = b.add_triangles(&quad(
        v(-3.8, -1.0, 4.5),
        v(-2.6, -1.0, 4.8),
        v(-2.6, 1.2, 4.8),
        v(-3.8, 1.2, 4.5),
    ));
    // The fence: a row of tall panels, each a grid of small triangles.
    let mut fence = Vec::new();
    for i in 0..12 {
        for j in 0..6 {
            let (x, y) = (-6.0 + i as f32, -1.0 + 0.5 * j as f32);
            fence.extend(quad(
                v(x, y, 12.0),
                v(x + 1.0, y, 12.0),
                v(x + 1.0, y + 0.5, 12.0),
                v(x, y + 0.5, 12.0),
            ));
        }
    }
    let fence = b.add_triangles(&fence);
    // Camera rays see the glass; shadow rays pass through it.
    b.set_mask(glass, CAMERA)?;
    Ok((b.build(Quality::Medium)?, [floor, glass, fence]))
}

/// The fence's alpha test: a lattice of holes in each triangle.
fn opaque(fence: GeometryId) -> impl Fn(&SceneHit) -> bool {
    move |h| h.geometry != fence || ((h.u * 4.0).floor() + (h.v * 4.0).floor()) as i32 % 2 == 0
}

/// A tetrahedron around the origin.
fn spinner() -> Vec<Triangle> {
    let (a, b, c, d) = (
        Vec3A::new(0.0, 0.9, 0.0),
        Vec3A::new(-0.8, -0.5, -0.5),
        Vec3A::new(0.8, -0.5, -0.5),
        Vec3A::new(0.0, -0.5, 0.9),
    );
    vec![
        Triangle::new(a, b, c),
        Triangle::new(a, c, d),
        Triangle::new(a, d, b),
        Triangle::new(b, d, c),
    ]
}

/// The spinner's placement at `frame`: orbiting the middle of the scene and turning.
fn orbit(frame: usize) -> Affine3A {
    let a = 0.6 * frame as f32;
    Affine3A::from_scale_rotation_translation(
        Vec3::splat(1.6),
        glam::Quat::from_rotation_y(2.0 * a),
        Vec3::new(-0.5 + 1.8 * a.cos(), 0.0, 7.0 + 1.2 * a.sin()),
    )
}

/// The flag's triangles at `frame`: a 24 × 12 grid waving along z.
fn flag(frame: usize) -> Vec<Triangle> {
    let (nx, ny) = (24, 12);
    let p = |i: usize, j: usize| {
        let x = 1.5 + 3.5 * i as f32 / nx as f32;
        let y = 2.5 * j as f32 / ny as f32 - 0.6;
        let z = 6.0 + 0.5 * (1.7 * x + 0.9 * frame as f32).sin() * (x - 1.5) / 3.5;
        Vec3A::new(x, y, z)
    };
    let mut t = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            t.extend(quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)));
        }
    }
    t
}

/// What a ray hit first.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Seen {
    Nothing,
    Scene(SceneHit),
    Spinner(f32, Vec3A),
    Flag(f32, Vec3A),
}

impl Seen {
    fn t(&self) -> f32 {
        match self {
            Seen::Nothing => f32::INFINITY,
            Seen::Scene(h) => h.t,
            Seen::Spinner(t, _) | Seen::Flag(t, _) => *t,
        }
    }
}

/// The three structures of one frame.
struct World<'a> {
    scene: &'a Scene,
    ids: [GeometryId; 3],
    spinner: &'a Instances,
    flag: &'a Accel,
}

impl World<'_> {
    /// The closest hit of a camera ray, checked against brute force.
    fn trace(&self, ray: &Ray) -> Seen {
        let keep = opaque(self.ids[2]);
        let s = self.scene.closest_hit_filtered(ray, CAMERA, &keep);
        let mut f = |h: &SceneHit| keep(h);
        assert_eq!(s, self.scene.brute_closest_hit(ray, CAMERA, Some(&mut f)));
        let i = self.spinner.closest_hit(ray, CAMERA);
        assert_eq!(i, self.spinner.brute_closest_hit(ray, CAMERA));
        let a = self.flag.closest_hit(ray);
        assert_eq!(a, self.flag.brute_closest_hit(ray));
        let mut best = Seen::Nothing;
        let mut offer = |s: Seen| {
            if s.t() < best.t() {
                best = s;
            }
        };
        if let Some(h) = s {
            offer(Seen::Scene(h));
        }
        if let Some(h) = i {
            offer(Seen::Spinner(h.t, h.normal));
        }
        if let Some(h) = a {
            offer(Seen::Flag(h.t, h.normal));
        }
        best
    }

    /// True when something blocks the segment (shadow rays: the glass lets light through, the
    /// fence's holes too), checked against brute force.
    fn blocked(&self, ray: &Ray) -> bool {
        let keep = opaque(self.ids[2]);
        let s = self.scene.any_hit_filtered(ray, SHADOW, &keep);
        let mut f = |h: &SceneHit| keep(h);
        assert_eq!(s, self.scene.brute_any_hit(ray, SHADOW, Some(&mut f)));
        let i = self.spinner.any_hit(ray, SHADOW);
        assert_eq!(i, self.spinner.brute_any_hit(ray, SHADOW));
        let a = self.flag.any_hit(ray);
        assert_eq!(a, brute::any_hit(self.flag.triangles(), ray));
        s || i || a
    }
}

/// Counts of one frame: pixels per object (nothing, floor, glass, fence, spinner, flag),
/// pixels in shadow and a checksum of the image.
#[derive(Debug, Default, PartialEq)]
struct Frame {
    counts: [usize; 6],
    shadowed: usize,
    checksum: u64,
}

/// Renders `frames` frames (printing them when `print`); returns their counts.
fn render(frames: usize, print: bool) -> Result<Vec<Frame>, sahara::Error> {
    let (scene, ids) = static_scene()?;
    let mut spinner = Instances::build(
        vec![Accel::build(&spinner(), Quality::Fast)?],
        &[(0, orbit(0))],
        Quality::Fast,
    )?;
    spinner.set_mask(0, CAMERA | SHADOW)?;
    let mut waving = Accel::build(&flag(0), Quality::High)?;
    // Bad input is a typed error and changes nothing.
    assert!(waving.refit(&flag(0)[1..]).is_err());
    let light = Vec3A::new(-3.0, 5.0, 1.0);
    let eye = Vec3A::new(0.0, 1.2, -1.0);
    let mut out = Vec::new();
    for f in 0..frames {
        spinner.set_transform(0, orbit(f))?;
        waving.refit(&flag(f))?;
        let world = World {
            scene: &scene,
            ids,
            spinner: &spinner,
            flag: &waving,
        };
        let mut frame = Frame {
            checksum: 0xcbf2_9ce4_8422_2325,
            ..Frame::default()
        };
        let mut image = String::new();
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let dir = Vec3A::new(
                    (x as f32 + 0.5) / WIDTH as f32 * 2.0 - 1.0,
                    0.5 - (y as f32 + 0.5) / HEIGHT as f32 * 1.2,
                    1.0,
                );
                let seen = world.trace(&Ray::new(eye, dir, 0.0, f32::INFINITY));
                let (object, normal) = match seen {
                    Seen::Nothing => (0, Vec3A::ZERO),
                    Seen::Scene(h) => (
                        1 + ids.iter().position(|&g| g == h.geometry).unwrap(),
                        h.normal,
                    ),
                    Seen::Spinner(_, n) => (4, n),
                    Seen::Flag(_, n) => (5, n),
                };
                frame.counts[object] += 1;
                let c = if object == 0 {
                    ' '
                } else {
                    let p = eye + dir * seen.t();
                    let to_light = light - p;
                    let lit = !world.blocked(&Ray::new(p, to_light, 1e-3, 1.0));
                    frame.shadowed += !lit as usize;
                    let n = normal.normalize_or_zero();
                    let lambert = n.dot(to_light.normalize()).abs() * lit as u32 as f32;
                    let ramp: [&[u8]; 6] = [b"", b".:-=", b"'\"", b"+x#", b"oO@", b"~*%"];
                    let r = ramp[object];
                    r[((lambert * r.len() as f32) as usize).min(r.len() - 1)] as char
                };
                image.push(c);
                frame.checksum = (frame.checksum ^ c as u64).wrapping_mul(0x0100_0000_01b3);
            }
            image.push('\n');
        }
        if print {
            println!("{image}");
            let [none, floor, glass, fence, spin, flag] = frame.counts;
            println!(
                "frame {f}: floor {floor}, glass {glass}, fence {fence}, spinner {spin}, \
                 flag {flag}, background {none}; {} in shadow; checksum {:016x}\n",
                frame.shadowed, frame.checksum
            );
        }
        out.push(frame);
    }
    Ok(out)
}

fn main() -> Result<(), sahara::Error> {
    render(4, true)?;
    println!("every pixel equals brute force");
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn frames_equal_brute_force_and_show_every_object() {
        let frames = super::render(3, false).unwrap();
        for f in &frames {
            // Every object is on screen, and some of it in shadow.
            assert!(f.counts.iter().all(|&c| c > 0), "{f:?}");
            assert!(f.shadowed > 0);
        }
        // The spinner and the flag move: the frames differ.
        assert_ne!(frames[0].checksum, frames[1].checksum);
    }
}
