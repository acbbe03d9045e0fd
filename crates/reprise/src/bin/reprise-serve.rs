//! `reprise-serve`: see `reprise_serve` for what it does (`reprise serve` runs it on a pipeline).

use clap::Parser;

fn main() {
    let args = reprise_serve::Args::parse();
    if let Err(e) = reprise_serve::serve(&args) {
        reprise_stagekit::say_whole(&format!("reprise-serve: error: {e}\n"));
        std::process::exit(match e {
            reprise_serve::ServeError::Config(_) => 2,
            _ => 1,
        });
    }
}
