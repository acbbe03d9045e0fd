//! Protocol A on a real take (a first measurement; the stages and the report come next):
//! an ingested face take on a blendshape face (`frames.parquet` of `ingest --blendshapes`),
//! its landmark vertices as markers with Gaussian noise, the shape weights as targets.
//!
//!   cargo run --release -p reprise-retarget --example protocol_a -- FRAMES ZIP LANDMARKS [DRAWS [NOISE_M]]
//!
//! The first 70 % of the frames train (labelled or unlabelled), the last 25 % are mapped
//! (5 % between them left out: neighbouring frames of a 60 fps take are nearly copies).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use reprise_retarget::protocol::{compare, noise_levels, source_scale, Config, Init};
use reprise_retarget::source::Noise;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        eprintln!("usage: protocol_a FRAMES ZIP LANDMARKS [DRAWS [NOISE_M]]");
        std::process::exit(2);
    }
    let frames = reprise_artifact::frames::Frames::read(std::path::Path::new(&args[1])).expect("frames");
    let face = reprise_blendshape::Blendshapes::read_zip(std::path::Path::new(&args[2])).expect("zip");
    let landmarks: Vec<usize> =
        std::fs::read_to_string(&args[3]).expect("landmarks").lines().filter_map(|l| l.trim().parse().ok()).collect();
    let draws: usize = args.get(4).and_then(|v| v.parse().ok()).unwrap_or(5);
    let noise_m: f64 = args.get(5).and_then(|v| v.parse().ok()).unwrap_or(1e-3);
    assert_eq!(frames.controls, face.names, "the frames must be the face's shapes, in its order");
    let (n, dy, dx) = (frames.rows(), face.names.len(), 3 * landmarks.len());
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut gauss = move || {
        // Box–Muller.
        let (u1, u2): (f64, f64) = (rand::Rng::gen(&mut rng), rand::Rng::gen(&mut rng));
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let mut mesh = vec![0.0; 3 * face.vertex_count()];
    let mut x = Vec::with_capacity(n * dx);
    for r in 0..n {
        face.evaluate(frames.row(r), &mut mesh);
        for &v in &landmarks {
            for a in 0..3 {
                x.push(mesh[3 * v + a] + noise_m * gauss());
            }
        }
    }
    let train = 0..(n * 70 / 100);
    let test = (n * 75 / 100)..n;
    let env = |k: &str| std::env::var(k).ok();
    let cfg = Config {
        labels: env("RT_LABELS").map_or(vec![5, 10, 20], |v| v.split(',').filter_map(|s| s.parse().ok()).collect()),
        draws,
        unlabelled: env("RT_UNLABELLED").and_then(|v| v.parse().ok()).unwrap_or(100).min((train.len() - 20) / 2),
        q: env("RT_Q").and_then(|v| v.parse().ok()).unwrap_or(8),
        k: 8,
        alpha: 1e-3,
        noise: Noise { capture: 0.1, temporal: 1.0 },
        capture_noise: (env("RT_SIGMA").as_deref() != Some("fixed")).then_some(noise_m),
        temporal_from_data: env("RT_SIGMA").as_deref() != Some("fixed"),
        init: if env("RT_INIT").as_deref() == Some("pca") { Init::Pca } else { Init::Alignment },
        gaussian_prior: env("RT_GPRIOR").as_deref() != Some("0"),
        max_iters: env("RT_ITERS").and_then(|v| v.parse().ok()).unwrap_or(300),
        seed: 7,
    };
    println!(
        "{n} frames, {} markers ({noise_m} m noise), {dy} weights; train {train:?}, test {test:?}, {draws} draws",
        landmarks.len()
    );
    let scale = source_scale(&x, dx);
    println!(
        "{cfg:?}\nsource scale {scale:.4} m; per-frame noise (normalised) {:?}",
        noise_levels(&x, dx, scale, train.clone(), &cfg)
    );
    let rows = compare(&x, dx, frames.values.as_slice(), dy, train, test, &cfg).expect("compare");
    println!("| labels | method | weight RMS |\n|---|---|---|");
    for r in rows {
        println!("| {} | {:?} | {:.4} |", r.labels, r.method, r.rms);
    }
}
