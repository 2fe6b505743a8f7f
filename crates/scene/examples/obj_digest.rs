//! Loads scene files and prints, per file, its triangle count, the SHA-256 of its triangle
//! array (every vertex coordinate's bits, little-endian, in triangle order) and the load time.
//!
//! `cargo run --release -p sahara-scene --example obj_digest -- FILE...` (with `--repeat N`
//! first to load each file N times and print each time). Used to check that a change of
//! the OBJ reader keeps the loaded triangles bit-identical (`docs/robustness.md`).

use sha2::{Digest, Sha256};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut repeat = 1usize;
    if args.first().map(String::as_str) == Some("--repeat") && args.len() >= 2 {
        repeat = args[1].parse().expect("--repeat takes a count");
        args.drain(..2);
    }
    for file in &args {
        for _ in 0..repeat {
            let start = std::time::Instant::now();
            let mesh = match sahara_scene::load_mesh(file) {
                Ok(m) => m,
                Err(e) => {
                    eprintln!("{e}");
                    std::process::exit(1);
                }
            };
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let mut h = Sha256::new();
            for t in mesh.triangles() {
                for v in t.v {
                    for c in v.to_array() {
                        h.update(c.to_bits().to_le_bytes());
                    }
                }
            }
            let digest: String = h.finalize().iter().map(|b| format!("{b:02x}")).collect();
            println!("{file}\t{}\t{digest}\t{ms:.1} ms", mesh.triangle_count());
        }
    }
}
