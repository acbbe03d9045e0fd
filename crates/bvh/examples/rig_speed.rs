//! Measures forward-kinematics evaluations per second of the BVH rig on one thread.
//!
//! `cargo run --release -p reprise-bvh --example rig_speed [file.bvh]`
//! (default: CMU 131_01 from `../shared/datasets/cmu_bvh/`, read in place).

use std::path::PathBuf;
use std::time::Instant;

use reprise_bvh::{ingest, BvhRig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args_os().nth(1).map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets/cmu_bvh/131_01.bvh")
    });
    let started = Instant::now();
    let curves = ingest(&path, 120.0)?;
    let ingest_time = started.elapsed();
    let rig = BvhRig::open(&path)?;
    println!("{}", rig.describe());
    println!("ingest of {} frames at 120 fps: {:.1} ms", curves.frames, ingest_time.as_secs_f64() * 1e3);

    let points = 3 * rig.vertex_count();
    let mut out = vec![0.0; points];
    let mut checksum = 0.0;
    let (mut evaluations, started) = (0usize, Instant::now());
    while started.elapsed().as_secs_f64() < 2.0 {
        for k in 0..curves.frames {
            rig.evaluate(curves.frame(k), &mut out);
            checksum += out[points - 1];
        }
        evaluations += curves.frames;
    }
    let single = evaluations as f64 / started.elapsed().as_secs_f64();

    let mut batch = vec![0.0; curves.frames * points];
    let (mut batched, started) = (0usize, Instant::now());
    while started.elapsed().as_secs_f64() < 2.0 {
        rig.evaluate_batch(&curves.values, &mut batch);
        checksum += batch[batch.len() - 1];
        batched += curves.frames;
    }
    let batch_rate = batched as f64 / started.elapsed().as_secs_f64();

    println!("evaluate:       {single:.0} evaluations/s ({:.2} µs each)", 1e6 / single);
    println!("evaluate_batch: {batch_rate:.0} evaluations/s ({:.2} µs each)", 1e6 / batch_rate);
    println!("(checksum {checksum:.3})");
    Ok(())
}
