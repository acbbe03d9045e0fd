//! `reprise-bridges`: see `reprise_bridges` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_bridges::Args::parse();
    reprise_stagekit::main("reprise-bridges", reprise_stagekit::code_id!("REPRISE_CODE_ID_BRIDGES"), || {
        if let Some(out) = reprise_bridges::run(&args)? {
            if let (Some(m), Some(max)) = (out.frame_motion, out.max_mesh) {
                eprintln!(
                    "per-frame mesh motion at the chosen quantile {m:.4}; bridges keep mesh distances up to {max:.4}"
                );
            }
            eprintln!("{:<12} {:<12} {:>10} {:>5} {:>12}", "from", "to", "candidates", "kept", "best rig dist");
            for c in &out.counts {
                eprintln!("{:<12} {:<12} {:>10} {:>5} {:>12.4}", c.from, c.to, c.candidates, c.kept, c.best);
            }
            let none = out.counts.iter().filter(|c| c.kept == 0).count();
            if none > 0 {
                eprintln!(
                    "{none} of {} ordered pairs have no direct bridge (synthesis routes through a third label)",
                    out.counts.len()
                );
            }
        }
        Ok(())
    });
}
