//! `reprise-bridges`: see `reprise_bridges` for what it does.
use std::fmt::Write as _;
use std::io::Write as _;

use clap::Parser;

fn main() {
    let args = reprise_bridges::Args::parse();
    reprise_stagekit::main("reprise-bridges", reprise_stagekit::code_id!("REPRISE_CODE_ID_BRIDGES"), || {
        if let Some(out) = reprise_bridges::run(&args)? {
            // One write for the whole table: the runner may run several pairs side by side
            // on one stderr, and whole lines keep the log (and its readers) sane.
            let mut text = String::new();
            let _ = writeln!(
                text,
                "{:<12} {:<12} {:>10} {:>5} {:>12} {:>12} {:>12}",
                "from", "to", "candidates", "kept", "best rig dist", "frame motion", "max mesh"
            );
            let or_dash = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.4}"));
            for c in &out.counts {
                let _ = writeln!(
                    text,
                    "{:<12} {:<12} {:>10} {:>5} {:>12.4} {:>12} {:>12}",
                    c.from,
                    c.to,
                    c.candidates,
                    c.kept,
                    c.best,
                    or_dash(c.frame_motion),
                    or_dash(c.max_mesh)
                );
            }
            let none = out.counts.iter().filter(|c| c.kept == 0).count();
            if none > 0 {
                let _ = writeln!(
                    text,
                    "{none} of {} ordered pairs have no direct bridge (synthesis routes through a third label)",
                    out.counts.len()
                );
            }
            let _ = std::io::stderr().write_all(text.as_bytes());
        }
        Ok(())
    });
}
