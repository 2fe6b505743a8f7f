//! A renderer in one page: a sphere on a floor, built at each quality level, rendered as
//! ASCII art with primary rays (closest hit) and shadow rays (any hit), traced in batches;
//! then the structure is saved, loaded back and checked.
//!
//! ```sh
//! cargo run --release -p sahara --example ascii
//! ```

use std::time::Instant;

use sahara::{Accel, Quality, Ray, Vec3A};

/// A UV sphere of radius 1 at (0, 1, 0) on a 10 × 10 floor at y = 0, as an indexed mesh.
fn scene() -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let (stacks, slices) = (48u32, 96u32);
    let mut positions = Vec::new();
    for i in 0..=stacks {
        let theta = std::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..slices {
            let phi = std::f32::consts::TAU * j as f32 / slices as f32;
            let (s, c) = theta.sin_cos();
            positions.push(Vec3A::new(s * phi.cos(), 1.0 + c, s * phi.sin()));
        }
    }
    let mut indices = Vec::new();
    for i in 0..stacks {
        for j in 0..slices {
            let (a, b) = (i * slices + j, i * slices + (j + 1) % slices);
            let (c, d) = (a + slices, b + slices);
            indices.push([a, b, d]);
            indices.push([a, d, c]);
        }
    }
    let base = positions.len() as u32;
    for (x, z) in [(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)] {
        positions.push(Vec3A::new(x, 0.0, z));
    }
    indices.push([base, base + 1, base + 2]);
    indices.push([base, base + 2, base + 3]);
    (positions, indices)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (positions, indices) = scene();
    let (width, height) = (72usize, 28usize);
    let eye = Vec3A::new(0.0, 1.6, 4.5);
    let light = Vec3A::new(-3.0, 6.0, 3.0).normalize();
    let primary: Vec<Ray> = (0..width * height)
        .map(|p| {
            let x = ((p % width) as f32 + 0.5) / width as f32 * 2.0 - 1.0;
            let y = 1.0 - ((p / width) as f32 + 0.5) / height as f32 * 2.0;
            let dir = Vec3A::new(x * 1.2, y * 0.9 - 0.25, -1.0);
            Ray::new(eye, dir, 0.0, f32::INFINITY)
        })
        .collect();

    let mut last = None;
    for quality in Quality::ALL {
        let start = Instant::now();
        let accel = Accel::build_indexed(&positions, &indices, quality)?;
        let built = start.elapsed();
        let start = Instant::now();
        let hits = accel.closest_hits(&primary);
        println!(
            "{quality:>6} ({:>9}): {} triangles, built in {:>7.1?}, {} rays traced in {:.1?} on {}",
            quality.builder_name(),
            accel.len(),
            built,
            primary.len(),
            start.elapsed(),
            accel.backend(),
        );
        last = Some((accel, hits));
    }
    let (accel, hits) = last.expect("four levels");

    // Shadow rays from every hit point towards the light.
    let shadow: Vec<Ray> = primary
        .iter()
        .zip(&hits)
        .filter_map(|(ray, hit)| {
            let hit = hit.as_ref()?;
            let p = ray.origin + ray.direction() * hit.t;
            Some(Ray::new(p, light, 1e-3, f32::INFINITY))
        })
        .collect();
    let mut occluded = accel.any_hits(&shadow).into_iter();
    let mut image = String::new();
    for (p, (ray, hit)) in primary.iter().zip(&hits).enumerate() {
        image.push(match hit {
            None => ' ',
            Some(hit) => {
                let mut n = hit.normal.normalize();
                if n.dot(ray.direction()) > 0.0 {
                    n = -n;
                }
                let lit = if occluded.next() == Some(true) {
                    0.0
                } else {
                    n.dot(light).max(0.0)
                };
                b".:-=+*#%@"[((lit * 8.0).round() as usize).min(8)] as char
            }
        });
        if p % width == width - 1 {
            image.push('\n');
        }
    }
    print!("{image}");

    // Cache the structure: save it, load it back, and check it answers the same.
    let path = std::env::temp_dir().join(format!("sahara-ascii-{}.accel", std::process::id()));
    accel.save_to_path(&path)?;
    let bytes = std::fs::metadata(&path)?.len();
    let start = Instant::now();
    let loaded = Accel::load_from_path(&path)?;
    let load_time = start.elapsed();
    std::fs::remove_file(&path)?;
    assert_eq!(loaded.closest_hits(&primary), hits);
    println!("saved {bytes} bytes, loaded back in {load_time:.1?} (checks and layout): same hits");
    Ok(())
}
