//! The live benchmark: every system stepping one character on one core, a command every
//! two seconds (each label in turn), per-step times, the rig's evaluation time, and a
//! check that the replay of the session gives the same frames.
//!
//! ```text
//! cargo run --release -p reprise-live --example live_bench -- ARTIFACT_DIR [SECONDS]
//! ```
//! run from the pipeline's directory (the rig's paths are relative to it).

use std::time::Instant;

use reprise_live::command::LiveCommand;
use reprise_live::session::{replay, Session};
use reprise_live::systems::{character, SYSTEM_IDS};
use reprise_live::world::{Paths, Tuning, World};

fn quantiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    (q(0.5), q(0.99), v.iter().sum::<f64>() / v.len() as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args.get(1).expect("usage: live_bench ARTIFACT_DIR [SECONDS]");
    let seconds: f64 = args.get(2).map_or(60.0, |s| s.parse().expect("SECONDS"));
    let t = Instant::now();
    let world = World::load(&Paths::in_dir(std::path::Path::new(dir)), Tuning::default()).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    println!(
        "loaded {} labels, {} controls in {:.2} s",
        world.labels.len(),
        world.controls.len(),
        t.elapsed().as_secs_f64()
    );
    let frames = (seconds * world.fps) as usize;
    let every = (2.0 * world.fps) as usize;
    let label = |i: usize| world.labels[(i / every + 1) % world.labels.len()].clone();
    let start = &world.labels[0];
    let row = world.start_row(0).expect("a start");
    println!("{:<16} {:>10} {:>10} {:>10}   (ms per step, {frames} frames)", "system", "p50", "p99", "mean");
    for id in SYSTEM_IDS {
        let mut c = character(world, id, row, 1).unwrap();
        let mut times = Vec::with_capacity(frames);
        for f in 0..frames {
            let t = Instant::now();
            if f > 0 && f % every == 0 {
                c.command(&LiveCommand::Transition { to: label(f), blend_frames: None });
            }
            std::hint::black_box(c.step());
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let (p50, p99, mean) = quantiles(times);
        println!("{id:<16} {p50:>10.4} {p99:>10.4} {mean:>10.4}");
    }
    let pose = world.labeled.frames.row(row).to_vec();
    let mut times = Vec::new();
    for _ in 0..200 {
        let t = Instant::now();
        std::hint::black_box(world.mesh(&pose).unwrap());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let (p50, p99, mean) = quantiles(times);
    println!(
        "{:<16} {p50:>10.4} {p99:>10.4} {mean:>10.4}   ({} vertices)",
        "rig evaluation",
        world.rig.0.vertex_count()
    );
    // Four systems side by side, with the rig, then the replay.
    let systems: Vec<String> = ["reprise", "motion-graphs", "motion-matching", "crossfade"].map(String::from).to_vec();
    let mut s = Session::new(world, &systems, start, 3).unwrap();
    let (mut live, mut times) = (Vec::with_capacity(frames), Vec::with_capacity(frames));
    for f in 0..frames {
        let t = Instant::now();
        if f > 0 && f % every == 0 {
            s.command(LiveCommand::Transition { to: label(f), blend_frames: None }).unwrap();
        }
        let out = s.step();
        for fr in &out {
            std::hint::black_box(world.mesh(&fr.controls).unwrap());
        }
        times.push(t.elapsed().as_secs_f64() * 1e3);
        live.push(out);
    }
    let (p50, p99, mean) = quantiles(times);
    println!("{:<16} {p50:>10.4} {p99:>10.4} {mean:>10.4}   (a frame of four systems with the rig)", "session");
    let again = replay(world, s.recording()).unwrap();
    assert!(again == live, "the replay differs from the session");
    println!("replay of {} frames and {} commands: identical", frames, s.recording().commands.len());
}
