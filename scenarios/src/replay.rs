//! `scenarios replay`: runs one filter of the library on measurements given as
//! JSON and writes the estimates as JSON, so that other implementations
//! (filterpy in the Python suite) can be compared on identical data.

/// Command-line arguments of `scenarios replay`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: &Args) -> anyhow::Result<()> {
    anyhow::bail!("replay is not implemented yet")
}
