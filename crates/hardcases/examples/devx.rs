// TEMP-DEV: runs xtask/src/hardcases.rs without touching xtask/src/main.rs.
#[path = "../../../xtask/src/hardcases.rs"]
mod hardcases;
use clap::Parser;
#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    a: hardcases::Args,
}
fn main() -> anyhow::Result<()> {
    hardcases::run(Cli::parse().a)
}
