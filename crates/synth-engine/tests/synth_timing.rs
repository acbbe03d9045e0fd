//! Synthesis cost per frame (a benchmark, not a timed test): particle step (2 RK4 substeps,
//! density and random forces) plus reconstruction to all 742 controls, for an N = 800,
//! d = 8, q = 3 model, under the paper's method and the tuned one (the reference beside it).
//! Run with
//! `cargo test --release -p reprise-synth-engine --test synth_timing -- --ignored --nocapture`.

use reprise_numerics::gplvm::{Hyper, LatentModel, LikelihoodConfig, Predictor, RigMap};
use reprise_synth_engine::engine::{run, Library, Settings, TrainingFrame};
use reprise_synth_engine::script::{Command, Script, Start};

#[test]
#[ignore]
fn cost_per_frame() {
    let (n, d, q, c) = (800, 8, 3, 742);
    let x: Vec<f64> = (0..n)
        .flat_map(|i| {
            let t = i as f64 * 0.01;
            [t.cos() * 1.5, (2.0 * t).sin(), (0.5 * t).cos()]
        })
        .collect();
    let y: Vec<f64> = (0..n * d)
        .map(|i| ((i * 37 % 101) as f64 / 50.0 - 1.0) * 0.1 + (x[(i / d) * q] * (i % d) as f64).sin())
        .collect();
    let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.5, white_variance: 1e-2 };
    let pred = Predictor::new(&x, &y, d, hyper, &LikelihoodConfig::default()).unwrap();
    let dirs: Vec<f64> = (0..d * c).map(|i| ((i * 7919 % 1000) as f64 / 1000.0 - 0.5) * 0.1).collect();
    let map = RigMap::from_pca(&vec![0.0; c], &dirs, &vec![0.0; c], &vec![1.0; c]).unwrap();
    let model = LatentModel::new("m".into(), pred, x.clone(), vec![0.0; d], map).unwrap();
    let frames: Vec<TrainingFrame> = (0..n)
        .map(|i| TrainingFrame { segment: 0, clip: "c".into(), frame: i as i64, x: x[i * q..(i + 1) * q].to_vec() })
        .collect();
    println!(
        "| method | N | d | controls | frames | µs per frame | × real time at 24 fps |\n|---|---|---|---|---|---|---|"
    );
    for (name, s) in [("paper", Settings::paper()), ("tuned (default)", Settings::default())] {
        let lib = Library::new(vec![&model], vec![frames.clone()], vec![], &s);
        let start = Start { label: "m".into(), segment: Some(0), clip: None, frame: Some(0), latent: None };
        let idle = Command::Idle { duration: 100.0, radius: Some(0.3), poses: vec![], hover: None };
        let script = Script { name: None, seed: 1, start, commands: vec![idle] };
        run(&lib, &script, &s).unwrap();
        let t = std::time::Instant::now();
        let out = run(&lib, &script, &s).unwrap();
        let us = t.elapsed().as_secs_f64() * 1e6 / out.len() as f64;
        println!("| {name} | {n} | {d} | {c} | {} | {us:.1} | {:.0} |", out.len(), 1e6 / 24.0 / us);
    }
}
