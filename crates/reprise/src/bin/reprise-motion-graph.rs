//! `reprise-motion-graph`: see `reprise_motion_graph` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_motion_graph::Args::parse();
    reprise_stagekit::main("reprise-motion-graph", reprise_stagekit::code_id!("REPRISE_CODE_ID_MOTION_GRAPH"), || {
        if let Some(s) = reprise_motion_graph::run(&args)? {
            eprintln!(
                "{} local minima, {} transitions (windowed distance ≤ {:.4}); {} of {} frames survive pruning",
                s.minima, s.transitions, s.threshold, s.frames_in_scc, s.frames
            );
            for (label, frames, alive) in &s.per_label {
                eprintln!("  {label:<12} {alive:>5} / {frames:<5} frames in the largest strongly connected component");
            }
        }
        Ok(())
    });
}
