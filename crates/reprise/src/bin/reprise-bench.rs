//! `reprise-bench`: the benchmarks, one command. Prints a Markdown report of
//! - the default pipeline: seconds and peak memory per stage, and a no-op rerun;
//! - rig evaluations per second (dragon-face; CMU BVH where `../shared/datasets` exists);
//! - ingest of a 20-minute, 742-control corpus (28,800 frames) from a Parquet curve table;
//! - the whole pipeline on a 20-minute dragon-face corpus: seconds and peak memory per stage.
//!
//! Run from the repository root after `cargo build --release`:
//! `target/release/reprise-bench`.
//!
//! `target/release/reprise-bench --sparse` instead measures the sparse (DTC) GPLVM (#32):
//! one evaluation for N ∈ {1k, 4k, 16k, 64k} × M ∈ {25, 50, 100, 200} inducing points
//! beside the dense likelihood where it is feasible; whole fits with held-out error for
//! N up to `--fit-max-n` against the dense fit up to N = 4k; and the gplvm stage on the
//! default corpus (the paper's scale) dense and sparse.
//!
//! `target/release/reprise-bench --film` runs only the film-scale pipeline.
//!
//! `target/release/reprise-bench --verdicts-seed 8` instead runs the default pipeline on the
//! corpus of `pipeline.toml` and on the corpus generated with seed 8, and lists, per headline
//! metric, the verdict of each and whether it survives.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use clap::Parser;
use reprise_rig::Rig;

/// Runs reprise's benchmarks and prints a Markdown report.
#[derive(Parser)]
#[command(name = "reprise-bench", version, about)]
struct Args {
    /// Repository root (holds pipeline.toml and datasets/).
    #[arg(long, default_value = ".")]
    repo: PathBuf,
    /// Minutes of animation for the large-ingest benchmark.
    #[arg(long, default_value_t = 20.0)]
    minutes: f64,
    /// Instead of the benchmarks: rerun the default pipeline on the dragon-face corpus of
    /// this generator seed and list which of the default run's verdicts survive.
    #[arg(long, value_name = "SEED")]
    verdicts_seed: Option<u64>,
    /// Instead of the benchmarks: the sparse GPLVM's costs, fits and held-out errors.
    #[arg(long)]
    sparse: bool,
    /// Instead of the benchmarks: only the film-scale pipeline (--minutes of dragon-face).
    #[arg(long)]
    film: bool,
    /// With --sparse: the largest N of the fit table (fits at 64,000 frames take tens of
    /// minutes each).
    #[arg(long, default_value_t = 16_000)]
    fit_max_n: usize,
}

fn main() {
    let args = Args::parse();
    if let Err(e) = bench(&args) {
        eprintln!("reprise-bench: error: {e}");
        std::process::exit(1);
    }
}

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn bin(name: &str) -> PathBuf {
    std::env::current_exe().expect("own path").with_file_name(name)
}

fn bench(args: &Args) -> Result<()> {
    if let Some(seed) = args.verdicts_seed {
        return verdicts(args, seed);
    }
    if args.film {
        return film_scale(args, tempfile::tempdir()?.path());
    }
    if args.sparse {
        sparse_costs()?;
        sparse_stage(args)?;
        return sparse_fits(args.fit_max_n);
    }
    let dir = tempfile::tempdir()?;
    println!("# reprise benchmarks\n");
    println!("{} logical CPUs; every number below is from this run\n", num_cpus());
    pipeline(args, dir.path())?;
    rigs(args, dir.path())?;
    big_ingest(args, dir.path())?;
    let big = tempfile::tempdir()?;
    film_scale(args, big.path())?;
    Ok(())
}

fn num_cpus() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// Runs `pipeline_toml` (with `labels` as datasets/dragon-face/labels.toml) in `dir`,
/// then once more with nothing changed; returns both wall times and the lock file.
fn run_pipeline(dir: &Path, pipeline_toml: &str, labels: &str) -> Result<(f64, f64, serde_json::Value)> {
    std::fs::create_dir_all(dir.join("datasets/dragon-face"))?;
    std::fs::write(dir.join("pipeline.toml"), pipeline_toml)?;
    std::fs::write(dir.join("datasets/dragon-face/labels.toml"), labels)?;
    let run = || -> Result<f64> {
        let t = Instant::now();
        let out = Command::new(bin("reprise")).arg("run").current_dir(dir).output()?;
        if !out.status.success() {
            return Err(format!("the pipeline failed: {}", String::from_utf8_lossy(&out.stderr)).into());
        }
        Ok(t.elapsed().as_secs_f64())
    };
    let first = run()?;
    let again = run()?;
    let lock = serde_json::from_str(&std::fs::read_to_string(dir.join("artifacts/dragon-face/reprise.lock"))?)?;
    Ok((first, again, lock))
}

/// A Markdown table of each stage's seconds and peak memory from a lock file.
fn print_stages(lock: &serde_json::Value, first: f64, again: f64) {
    println!("| stage | seconds | peak memory (MB) |\n|---|---:|---:|");
    for (name, entry) in lock["stages"].as_object().into_iter().flatten() {
        let mb = entry["peak_rss_mb"].as_f64().map_or("-".into(), |m| format!("{m:.0}"));
        println!("| {name} | {:.2} | {mb} |", entry["seconds"].as_f64().unwrap_or(f64::NAN));
    }
    println!("| **whole run** | {first:.2} | |\n| no-op rerun | {again:.3} | |\n");
}

/// The default pipeline in a scratch copy, then a no-op rerun, and artifact sizes.
fn pipeline(args: &Args, dir: &Path) -> Result<()> {
    let toml = std::fs::read_to_string(args.repo.join("pipeline.toml"))?;
    let labels = std::fs::read_to_string(args.repo.join("datasets/dragon-face/labels.toml"))?;
    let (first, again, lock) = run_pipeline(dir, &toml, &labels)?;
    println!("## Default pipeline (dragon-face, 3,745 labeled frames)\n");
    print_stages(&lock, first, again);
    let mut sizes: Vec<(String, u64)> = std::fs::read_dir(dir.join("artifacts/dragon-face"))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "parquet"))
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.metadata().map_or(0, |m| m.len())))
        .collect();
    sizes.sort();
    println!("| artifact | size (KiB) |\n|---|---:|");
    for (name, bytes) in sizes {
        println!("| {name} | {:.0} |", bytes as f64 / 1024.0);
    }
    println!();
    Ok(())
}

/// The same pipeline on a dragon-face corpus of `minutes` minutes (every label's budget
/// scaled), with the labels file the generator writes for that corpus.
fn film_scale(args: &Args, dir: &Path) -> Result<()> {
    let scale = args.minutes * 60.0 * 24.0 / 3745.0;
    let toml = std::fs::read_to_string(args.repo.join("pipeline.toml"))?
        .replace("seed = 7\n", &format!("seed = 7\ncorpus_scale = {scale}\n"));
    let rig = reprise_dragon_face::DragonRig::new(7);
    let labels = reprise_dragon_face::labels_toml(&reprise_dragon_face::generate_corpus_scaled(&rig, 7, scale));
    let (first, again, lock) = run_pipeline(dir, &toml, &labels)?;
    let frames =
        reprise_artifact::frames::LabeledFrames::read(&dir.join("artifacts/dragon-face/labeled_frames.parquet"))?;
    println!(
        "## The pipeline at film scale ({} minutes: {} labeled frames × {} controls)\n",
        args.minutes,
        frames.frames.rows(),
        frames.frames.controls.len()
    );
    print_stages(&lock, first, again);
    Ok(())
}

/// The default pipeline on the shipped corpus and on the corpus of `seed` (rig and takes
/// both generated from it, the labels file the generator writes for it), each in a scratch
/// directory; prints each headline metric's verdict on both and whether it survives.
fn verdicts(args: &Args, seed: u64) -> Result<()> {
    use reprise_benchmark::verdict::Verdict;
    let toml = std::fs::read_to_string(args.repo.join("pipeline.toml"))?;
    let shipped = std::fs::read_to_string(args.repo.join("datasets/dragon-face/labels.toml"))?;
    let Some(base) =
        toml.lines().find_map(|l| l.trim().strip_prefix("seed = ").and_then(|v| v.trim().parse::<u64>().ok()))
    else {
        return Err("pipeline.toml has no `seed = N` line for the corpus".into());
    };
    let other = reprise_dragon_face::labels_toml(&reprise_dragon_face::generate_corpus_scaled(
        &reprise_dragon_face::DragonRig::new(seed),
        seed,
        1.0,
    ));
    let runs = [
        (base, toml.clone(), shipped),
        (seed, toml.replacen(&format!("seed = {base}\n"), &format!("seed = {seed}\n"), 1), other),
    ];
    let mut conclusions = Vec::new();
    for (s, toml, labels) in runs {
        let dir = tempfile::tempdir()?;
        let script = std::fs::read_to_string(args.repo.join("datasets/dragon-face/scripts/demo.toml"))?;
        std::fs::create_dir_all(dir.path().join("datasets/dragon-face/scripts"))?;
        std::fs::write(dir.path().join("datasets/dragon-face/scripts/demo.toml"), script)?;
        eprintln!("reprise-bench: the default pipeline on corpus seed {s} …");
        run_pipeline(dir.path(), &toml, &labels)?;
        let rows = reprise_evaluate::read_metrics(&dir.path().join("reports/dragon-face/metrics.parquet"))?;
        let systems: Vec<&str> = reprise_benchmark::systems::SYSTEMS.iter().map(|d| d.id).collect();
        conclusions.push((s, reprise_benchmark::Conclusions::new(&rows, &systems)));
    }
    let words = |v: &Verdict| match v {
        Verdict::Best { system, clear } => {
            format!("{}{}", reprise_benchmark::systems::shown(system), if *clear { "" } else { " (CIs overlap)" })
        }
        Verdict::Tie(t) => {
            format!("tie: {}", t.iter().map(|s| reprise_benchmark::systems::shown(s)).collect::<Vec<_>>().join(", "))
        }
        Verdict::NotRanked(_) => "not ranked".into(),
    };
    let winners = |v: &Verdict| match v {
        Verdict::Best { system, .. } => vec![system.clone()],
        Verdict::Tie(t) => t.clone(),
        Verdict::NotRanked(_) => vec![],
    };
    let ((a, first), (b, second)) = (&conclusions[0], &conclusions[1]);
    println!("## Verdicts on corpus seed {a} and seed {b}\n");
    println!("| metric | seed {a} | seed {b} | survives |\n|---|---|---|---|");
    let mut kept = 0;
    for (x, y) in first.rankings.iter().zip(&second.rankings) {
        let survives = winners(&x.verdict) == winners(&y.verdict);
        kept += usize::from(survives && !winners(&x.verdict).is_empty());
        println!(
            "| `{}` | {} | {} | {} |",
            x.metric.id,
            words(&x.verdict),
            words(&y.verdict),
            if winners(&x.verdict).is_empty() {
                "–"
            } else if survives {
                "yes"
            } else {
                "**no**"
            }
        );
    }
    let ranked = first.rankings.iter().filter(|r| !winners(&r.verdict).is_empty()).count();
    println!("\n{kept} of {ranked} ranked verdicts survive (the same best system, or the same tie).");
    Ok(())
}

/// Poses per second through `Rig::evaluate_batch` (all cores).
fn rate(rig: &dyn Rig, poses: &[f64]) -> Result<f64> {
    let n = poses.len() / rig.control_names().len();
    let mut out = vec![0.0; n * 3 * rig.vertex_count()];
    rig.evaluate_batch(poses, &mut out)?; // warm-up
    let t = Instant::now();
    let mut reps = 0;
    while t.elapsed().as_secs_f64() < 1.0 {
        rig.evaluate_batch(poses, &mut out)?;
        reps += 1;
    }
    Ok((reps * n) as f64 / t.elapsed().as_secs_f64())
}

fn rigs(args: &Args, dir: &Path) -> Result<()> {
    println!("## Rig evaluations per second ({} threads)\n", num_cpus());
    println!("| rig | controls | vertices | evaluations/s |\n|---|---:|---:|---:|");
    let frames = reprise_artifact::frames::Frames::read(&dir.join("artifacts/dragon-face/frames.parquet"))?;
    let dragon = reprise_rig::dragon::open(7, reprise_dragon_face::DragonRig::VERSION)?;
    let poses: Vec<f64> = frames.values[..1000.min(frames.rows()) * frames.controls.len()].to_vec();
    let r = rate(&dragon, &poses)?;
    println!("| dragon-face | {} | {} | {r:.0} |", frames.controls.len(), dragon.vertex_count());
    let cmu = args.repo.join("../shared/datasets/cmu_bvh/131_01.bvh");
    if cmu.exists() {
        let hash = reprise_artifact::provenance::hash_file(&cmu)?;
        let rig = reprise_rig::skeleton::open_bvh(Path::new("/"), &cmu.canonicalize()?.display().to_string(), &hash)?;
        let poses: Vec<f64> = (0..1000).flat_map(|_| rig.rest_pose()).collect();
        let r = rate(&rig, &poses)?;
        println!("| CMU BVH 131_01 | {} | {} | {r:.0} |", rig.control_names().len(), rig.vertex_count());
    } else {
        println!("| CMU BVH | skipped: ../shared/datasets not found | | |");
    }
    let robot = args.repo.join("../shared/datasets/robot_expressive/RobotExpressive.glb");
    if robot.exists() {
        let hash = reprise_artifact::provenance::hash_file(&robot)?;
        let path = robot.canonicalize()?.display().to_string();
        let rig = reprise_rig::skeleton::open_gltf(Path::new("/"), &path, &hash)?;
        let poses: Vec<f64> = (0..500).flat_map(|_| rig.rest_pose()).collect();
        let r = rate(&rig, &poses)?;
        println!("| RobotExpressive (glTF) | {} | {} | {r:.0} |", rig.control_names().len(), rig.vertex_count());
    } else {
        println!("| RobotExpressive | skipped: ../shared/datasets not found | | |");
    }
    println!();
    Ok(())
}

/// A `minutes`-long wide Parquet curve table (tiled from the dragon-face corpus),
/// ingested by the real stage binary: the curve-table path at film scale.
fn big_ingest(args: &Args, dir: &Path) -> Result<()> {
    use reprise_artifact::{table, Columns, Kind, Provenance};
    let frames = reprise_artifact::frames::Frames::read(&dir.join("artifacts/dragon-face/frames.parquet"))?;
    let rows = (args.minutes * 60.0 * 24.0).round() as usize;
    let clip_len = 1200;
    let mut cols = Columns::new()
        .str("clip", &(0..rows).map(|r| format!("shot{:03}", r / clip_len)).collect::<Vec<_>>())
        .i64("frame", (0..rows).map(|r| (r % clip_len) as i64).collect());
    for (c, name) in frames.controls.iter().enumerate() {
        cols =
            cols.f64(name, (0..rows).map(|r| frames.values[(r % frames.rows()) * frames.controls.len() + c]).collect());
    }
    let path = dir.join("big.parquet");
    table::write(
        &path,
        Kind { name: "curves", version: 1 },
        cols,
        &Provenance::new("bench", "0", serde_json::json!({})),
        &[],
    )?;
    let stats = dir.join("big.stats.json");
    let t = Instant::now();
    let out = Command::new(bin("reprise-ingest"))
        .args([
            "--curves",
            "big.parquet",
            "--frames",
            "bf.parquet",
            "--controls",
            "bc.parquet",
            "--clips",
            "bk.parquet",
        ])
        .current_dir(dir)
        .env(reprise_stagekit::STATS_ENV, &stats)
        .output()?;
    let seconds = t.elapsed().as_secs_f64();
    if !out.status.success() {
        return Err(format!("ingest failed: {}", String::from_utf8_lossy(&out.stderr)).into());
    }
    let peak: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats)?)?;
    println!("## Ingest of a {}-minute curve table\n", args.minutes);
    println!(
        "{rows} frames × {} controls from a {:.0} MiB Parquet table: {seconds:.2} s, peak memory {:.0} MB\n",
        frames.controls.len(),
        std::fs::metadata(&path)?.len() as f64 / 1_048_576.0,
        peak["peak_rss_bytes"].as_f64().unwrap_or(0.0) / 1_048_576.0
    );
    Ok(())
}

/// Seconds of the fastest of `runs` calls of `f`.
fn fastest(runs: usize, mut f: impl FnMut()) -> f64 {
    (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// One evaluation (value and every gradient) of the sparse likelihood for N × M, and of the
/// dense one where it fits in a few seconds, on a smooth 3-D latent curve seen in 32
/// outputs; ratios against the dense evaluation at N = 1,000 measured in this run.
fn sparse_costs() -> Result<()> {
    use reprise_numerics::gplvm::sparse::SparseLikelihood;
    use reprise_numerics::gplvm::{Hyper, Likelihood, LikelihoodConfig};
    let (q, d) = (3, 32);
    let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.5, white_variance: 0.01 };
    let data = |n: usize| {
        let x: Vec<f64> = (0..n)
            .flat_map(|i| {
                let t = 6.0 * i as f64 / n as f64;
                [t.sin(), (1.3 * t).cos(), 0.2 * t - 0.6]
            })
            .collect();
        let y: Vec<f64> = x
            .chunks_exact(q)
            .flat_map(|p| (0..d).map(move |j| (p[j % q] * (1.0 + j as f64 * 0.1) + p[(j + 1) % q]).sin()))
            .collect();
        (x, y)
    };
    let dense_at = |n: usize| -> Result<f64> {
        let (x, y) = data(n);
        let mut lik = Likelihood::new(&y, d, q, LikelihoodConfig::default())?;
        let mut g = vec![0.0; x.len()];
        Ok(fastest(if n <= 1000 { 3 } else { 1 }, || {
            lik.evaluate(&x, &hyper, &mut g).expect("a dense evaluation");
        }))
    };
    let reference = dense_at(1000)?;
    println!("# The sparse GPLVM likelihood (DTC; the bound's trace term adds O(NM)): one evaluation\n");
    println!(
        "{} logical CPUs; q = {q}, D = {d}; value and every gradient; the reference is one dense evaluation at \
         N = 1,000 in this run: {:.4} s\n",
        num_cpus(),
        reference
    );
    println!("| N | dense (s) | M = 25 | M = 50 | M = 100 | M = 200 |\n|---:|---:|---:|---:|---:|---:|");
    for n in [1_000, 4_000, 16_000, 64_000] {
        let dense = if n <= 4_000 {
            let secs = dense_at(n)?;
            format!("{secs:.3} ({:.1} ×)", secs / reference)
        } else {
            "–".into()
        };
        let (x, y) = data(n);
        let lik = SparseLikelihood::new(&y, d, q)?;
        let mut cells = Vec::new();
        for m in [25, 50, 100, 200] {
            let u: Vec<f64> = x.chunks_exact(q).step_by(n / m).take(m).flatten().copied().collect();
            let (mut gx, mut gu) = (vec![0.0; x.len()], vec![0.0; u.len()]);
            let secs = fastest(3, || {
                lik.evaluate(&x, &u, &hyper, &mut gx, &mut gu).expect("a sparse evaluation");
            });
            cells.push(format!("{secs:.4} ({:.3} ×)", secs / reference));
        }
        println!("| {n} | {dense} | {} |", cells.join(" | "));
    }
    println!("\nDense beyond N = 4,000 is not run: one evaluation costs N³ (about 64 × the N = 4,000 one at 16,000).");
    Ok(())
}

/// The fit data of [`sparse_costs`]'s curve: `n` frames in segments of 240 (10 s at 24 fps)
/// of a smooth 3-D latent path seen through 32 nonlinear outputs plus noise of 2 % of their
/// spread: (Y, frame times in seconds, segment ids).
fn curve_data(n: usize) -> (Vec<f64>, Vec<f64>, Vec<i64>) {
    let d = 32;
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let y = (0..n)
        .flat_map(|i| {
            let t = 6.0 * i as f64 / n as f64 + (i / 240) as f64 * 0.37;
            let p = [t.sin(), (1.3 * t).cos(), 0.2 * (t % 6.0) - 0.6];
            (0..d).map(move |j| (p[j % 3] * (1.0 + j as f64 * 0.1) + p[(j + 1) % 3]).sin()).collect::<Vec<_>>()
        })
        .map(|v| v + 0.07 * noise())
        .collect();
    let times = (0..n).map(|i| (i % 240) as f64 / 24.0).collect();
    let segments = (0..n).map(|i| (i / 240) as i64).collect();
    (y, times, segments)
}

/// The largest N [`sparse_fits`] fits dense: one dense evaluation at N = 4,000 costs about
/// 50 × the N = 1,000 one (2.5 s here) and a fit takes thousands, hours in all.
const DENSE_FIT_MAX_N: usize = 1_000;

/// Whole fits under the gplvm stage's default settings on [`curve_data`], every 10th frame
/// held out: seconds, iterations, whether the fit converged, and the held-out frames' RMS
/// error through their best latent point, dense (N ≤ [`DENSE_FIT_MAX_N`]) and sparse.
fn sparse_fits(max_n: usize) -> Result<()> {
    use clap::Parser as _;
    use reprise_numerics::gplvm::{best_latent, fit, FitConfig, FitData, ProjectOptions};
    // The stage's defaults (its files are not read here).
    let files = ["--coords", "--labeled-frames", "--latents", "--models", "--trace", "--fits"];
    let argv = std::iter::once("reprise-gplvm").chain(files.iter().flat_map(|f| [*f, "unused"]));
    let base = reprise_gplvm::Args::try_parse_from(argv)?.fit_config();
    let d = 32;
    println!("\n## Whole fits, dense and sparse\n");
    println!(
        "The gplvm stage's default settings (both priors, the noise floor, L-BFGS to the window rule); a smooth \
         3-D path seen in {d} outputs with 2 % noise, in segments of 240 frames; every 10th frame held out and \
         found again through its best latent point. Error: RMS over the held-out values (outputs of unit size). \
         Ratios against the dense fit of the same N in this run.\n"
    );
    println!(
        "| N | fit | seconds | iterations | converged | held-out RMS | vs dense |\n|---:|---|---:|---:|---|---:|---:|"
    );
    for n in [1_000, 4_000, 16_000, 64_000].into_iter().filter(|&n| n <= max_n) {
        let (y, times, segments) = curve_data(n);
        let held: Vec<usize> = (0..n).filter(|i| i % 10 == 5).collect();
        let train: Vec<usize> = (0..n).filter(|i| i % 10 != 5).collect();
        let pick = |rows: &[usize], v: &[f64], w: usize| -> Vec<f64> {
            rows.iter().flat_map(|&i| v[i * w..(i + 1) * w].to_vec()).collect()
        };
        let (ty, tt) = (pick(&train, &y, d), pick(&train, &times, 1));
        let ts: Vec<i64> = train.iter().map(|&i| segments[i]).collect();
        let data = FitData { y: &ty, d, times: &tt, segments: &ts };
        let mut dense_err = None;
        let ms: Vec<Option<usize>> = [None, Some(25), Some(50), Some(100), Some(200)]
            .into_iter()
            .filter(|m| m.is_some() || n <= DENSE_FIT_MAX_N)
            .collect();
        for m in ms {
            let config = FitConfig { inducing: m, ..base.clone() };
            let t = Instant::now();
            let mut evals = 0;
            let f = fit(data, &config, |value| {
                evals += 1;
                if evals % 500 == 0 {
                    eprintln!("reprise-bench: N = {n}, M = {m:?}: evaluation {evals}, objective {value:.3}");
                }
            })?;
            let seconds = t.elapsed().as_secs_f64();
            let train_mu: Vec<f64> =
                f.x.chunks_exact(config.q)
                    .flat_map(|x| {
                        let mut mu = vec![0.0; d];
                        f.predictor.mean(x, &mut mu);
                        mu
                    })
                    .collect();
            let mut sq = 0.0;
            for &i in &held {
                let target: Vec<f64> = y[i * d..(i + 1) * d].iter().zip(&f.offset).map(|(v, o)| v - o).collect();
                let found = best_latent(&f.predictor, &target, &f.x, &train_mu, &ProjectOptions::default());
                sq += found.sq_error;
            }
            let rms = (sq / (held.len() * d) as f64).sqrt();
            if m.is_none() {
                dense_err = Some(rms);
            }
            let name = m.map_or("dense".to_string(), |m| format!("M = {m}"));
            let vs = dense_err.filter(|_| m.is_some()).map_or("–".into(), |e| format!("{:.3}", rms / e));
            println!(
                "| {n} | {name} | {seconds:.1} | {} | {} | {rms:.4} | {vs} |",
                f.info.iterations,
                if f.info.converged { "yes" } else { "NO" }
            );
        }
    }
    Ok(())
}

/// The gplvm stage on the default corpus (labels of a few hundred frames, the paper's
/// scale) dense, then sparse for every label at M ∈ {50, 100, 25}: the stage's summed
/// per-label fit seconds, whether every label converged, and the frame-weighted held-out
/// mesh error of its check, each against the dense run's in this run. Then the mixed-label
/// model of the paper's §7: every clip one label, one sparse GPLVM over all of them.
fn sparse_stage(args: &Args) -> Result<()> {
    let toml = std::fs::read_to_string(args.repo.join("pipeline.toml"))?;
    let labels = std::fs::read_to_string(args.repo.join("datasets/dragon-face/labels.toml"))?;
    let mixed = "[[rule]]\npattern = \"*\"\nlabel = \"all\"\n";
    println!("\n## The gplvm stage at the paper's scale (dragon-face), dense, sparse, and one mixed-label model\n");
    println!(
        "Fit seconds: the labels' fits summed (the held-out refits not counted). Held-out: every 10th frame left \
         out of PCA and GPLVM and found again, RMS vertex distance (cm) over every held-out frame of every label.\n"
    );
    println!(
        "| model | labels | fit seconds (sum) | × dense | converged | held-out mesh RMS | × dense |\n\
         |---|---:|---:|---:|---|---:|---:|"
    );
    let runs: [(&str, Option<usize>, &str); 6] = [
        ("eight labels, dense", None, &labels),
        ("eight labels, sparse M = 50", Some(50), &labels),
        ("eight labels, sparse M = 100", Some(100), &labels),
        ("eight labels, sparse M = 25", Some(25), &labels),
        ("one mixed label, sparse M = 100", Some(100), mixed),
        ("one mixed label, sparse M = 200", Some(200), mixed),
    ];
    let mut dense: Option<(f64, f64)> = None;
    for (name, m, labels) in runs {
        let dir = tempfile::tempdir()?;
        std::fs::create_dir_all(dir.path().join("datasets/dragon-face"))?;
        std::fs::write(dir.path().join("datasets/dragon-face/labels.toml"), labels)?;
        let rule = m.map_or(String::new(), |m| format!("\nsparse = \"always\"\ninducing = {m}"));
        let toml = toml.replace("heldout_every = 10", &format!("heldout_every = 10{rule}"));
        std::fs::write(dir.path().join("pipeline.toml"), toml)?;
        eprintln!("reprise-bench: gplvm, {name} …");
        let out = Command::new(bin("reprise")).args(["run", "--to", "gplvm"]).current_dir(dir.path()).output()?;
        if !out.status.success() {
            let why = String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("").to_string();
            println!("| {name} | refused: {why} | | | | | |");
            continue;
        }
        let fits = reprise_artifact::gplvm::read_fits(&dir.path().join("artifacts/dragon-face/gplvm_fits.parquet"))?;
        let seconds: f64 = fits.iter().map(|f| f.seconds).sum();
        let frames: f64 = fits.iter().map(|f| f.heldout_frames as f64).sum();
        // The RMS over every held-out frame of every label.
        let sq: f64 =
            fits.iter().map(|f| f.heldout_gplvm_mesh_rmse.unwrap_or(f64::NAN).powi(2) * f.heldout_frames as f64).sum();
        let held = (sq / frames).sqrt();
        let converged = fits.iter().filter(|f| f.converged).count();
        let (s0, h0) = *dense.get_or_insert((seconds, held));
        println!(
            "| {name} | {} | {seconds:.1} | {:.2} | {converged} of {} | {held:.4} | {:.3} |",
            fits.len(),
            seconds / s0,
            fits.len(),
            held / h0
        );
    }
    Ok(())
}
