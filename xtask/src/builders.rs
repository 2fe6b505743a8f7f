//! `cargo xtask builders`: the registered builders with their configurations.

/// Prints every registered builder: name, kind (object or spatial splits), summary and
/// configuration.
pub fn run() -> anyhow::Result<()> {
    println!("{:<18} {:<8} description / configuration", "name", "kind");
    for e in sahara_builders::registry::entries() {
        let b = (e.make)();
        let kind = if e.spatial { "spatial" } else { "object" };
        println!("{:<18} {:<8} {}", e.name, kind, e.summary);
        println!("{:<18} {:<8} {}", "", "", b.describe());
    }
    Ok(())
}
