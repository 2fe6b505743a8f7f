//! `cargo xtask scenes`: every scene the catalog finds.

use anyhow::Result;

#[derive(clap::Args)]
pub struct Args {
    /// Also check each file's SHA-256 against its folder's manifest.tsv.
    #[arg(long)]
    verify: bool,
    /// Do not load the scenes (print only what the catalog knows without reading files).
    #[arg(long)]
    no_load: bool,
}

pub fn run(a: Args) -> Result<()> {
    let catalog = sahara_scene::Catalog::discover();
    for w in catalog.warnings() {
        eprintln!("warning: {w}");
    }
    for (dir, origin) in catalog.dirs() {
        eprintln!("scene folder: {} ({origin:?})", dir.display());
    }
    println!(
        "{:<28} {:>10} {:<58} {:<10} source",
        "name", "triangles", "bounds", "check"
    );
    for e in catalog.entries() {
        let (tris, bounds, status) = if a.no_load {
            (
                e.triangles.map_or("?".to_string(), |t| t.to_string()),
                String::new(),
                String::new(),
            )
        } else {
            match catalog.load_entry(e) {
                Ok(s) => {
                    let b = s.bounds();
                    let n = s.triangle_count();
                    let count_ok = match e.triangles {
                        Some(expect) if expect != n => format!("COUNT {expect}?"),
                        _ => "ok".to_string(),
                    };
                    (
                        n.to_string(),
                        format!(
                            "({:.4}, {:.4}, {:.4})..({:.4}, {:.4}, {:.4})",
                            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
                        ),
                        count_ok,
                    )
                }
                Err(err) => ("-".into(), format!("error: {err}"), "ERROR".into()),
            }
        };
        let status = if a.verify && e.path().is_some() {
            match catalog.verify(&e.name) {
                Ok(true) => format!("{status} sha256 ok"),
                Ok(false) => format!("{status} SHA256 DIFFERS"),
                Err(err) => format!("{status} sha256 error: {err}"),
            }
        } else {
            status
        };
        println!(
            "{:<28} {:>10} {:<58} {:<10} {}",
            e.name,
            tris,
            bounds,
            status,
            e.source_label()
        );
    }
    Ok(())
}
