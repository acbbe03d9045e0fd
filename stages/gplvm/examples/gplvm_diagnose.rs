//! Which parameters of a GPLVM fit keep moving? Fits one label of a pipeline's artifacts
//! with the gplvm stage's configuration and prints, every `--every` evaluations, the
//! objective's parts, the hyperparameters ($\sigma_f^2$, the white variance used, both
//! relative to the mean per-dimension variance of $Y$), the latent scale (RMS of $X$), and
//! where the scaled gradient of the convergence rule sits (latents or which
//! hyperparameter).
//!
//! ```text
//! cargo run --release -p reprise-gplvm --example gplvm_diagnose -- \
//!     artifacts/dragon-face neutral 200 [stage flags, e.g. --max-iters 3000 --white-floor 1e-3]
//! ```
//! Arguments: the artifact directory, the label, the print interval in evaluations, then
//! any `reprise-gplvm` parameter flags.

use clap::Parser;
use reprise_gplvm::{read_labels, Args};
use reprise_numerics::gplvm::{fit_observed, Layout};
use reprise_numerics::optim::Convergence;

fn main() {
    let argv: Vec<String> = std::env::args().collect();
    if argv.len() < 4 {
        eprintln!("usage: gplvm_diagnose ARTIFACT_DIR LABEL EVERY [reprise-gplvm flags …]");
        std::process::exit(2);
    }
    let dir = std::path::Path::new(&argv[1]);
    let (label, every) = (&argv[2], argv[3].parse::<usize>().expect("EVERY must be an integer").max(1));
    let coords = dir.join("pca_coords.parquet");
    let frames = dir.join("labeled_frames.parquet");
    let mut stage_argv: Vec<String> =
        ["reprise-gplvm", "--latents", "-", "--models", "-", "--trace", "-", "--fits", "-"]
            .iter()
            .map(|s| (*s).to_string())
            .collect();
    stage_argv.extend(["--coords".into(), coords.display().to_string()]);
    stage_argv.extend(["--labeled-frames".into(), frames.display().to_string()]);
    stage_argv.extend(argv[4..].iter().cloned());
    let args = Args::parse_from(stage_argv);
    let config = args.fit_config();
    let labels = read_labels(&coords, &frames).expect("read the artifacts");
    let Some(data) = labels.iter().find(|l| &l.label == label) else {
        let names: Vec<&str> = labels.iter().map(|l| l.label.as_str()).collect();
        eprintln!("no label `{label}`; labels: {names:?}");
        std::process::exit(2);
    };
    let (n, d, q) = (data.n(), data.d, config.q);
    // The stage's per-label rule (dense, or sparse with M inducing points).
    let inducing = args.inducing_for(label, n).unwrap_or_else(|e| panic!("{e}"));
    let config = reprise_numerics::gplvm::FitConfig { inducing, ..config };
    let layout = Layout::new(n, q);
    // Mean per-dimension variance of the (centred) PCA coordinates.
    let mean: Vec<f64> = (0..d).map(|j| (0..n).map(|i| data.y[i * d + j]).sum::<f64>() / n as f64).collect();
    let var_y = (0..n * d).map(|k| (data.y[k] - mean[k % d]).powi(2)).sum::<f64>() / (n * d) as f64;
    println!("label {label}: N = {n}, d = {d}, q = {q}, mean var(Y) = {var_y:.4e}; config {:?}", config.likelihood);
    println!(
        "{:>6} {:>13} {:>12} {:>10} {:>10} {:>10} {:>10} {:>8} {:>9} {:>9} {:>5}",
        "eval", "E", "E_Y", "E_D", "E_C", "sf2/varY", "sw2/varY", "rmsX", "relgrad", "relgradX", "where"
    );
    let rule = Convergence { f_typical: (n * d) as f64, ..Default::default() };
    let mut count = 0usize;
    let start = std::time::Instant::now();
    let result = fit_observed(data.fit_data(), &config, |e| {
        count += 1;
        if !count.is_multiple_of(every) || !e.info.value.is_finite() {
            return;
        }
        let h = layout.hyper(e.params);
        let x = layout.x(e.params);
        let rms_x = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
        let scale = e.info.value.abs().max(rule.f_typical);
        let scaled: Vec<f64> = e.params.iter().zip(e.grad).map(|(p, g)| g.abs() * p.abs().max(1.0) / scale).collect();
        let (imax, gmax) = scaled.iter().enumerate().fold((0, 0.0), |b, (i, v)| if *v > b.1 { (i, *v) } else { b });
        let gx = scaled[..n * q].iter().copied().fold(0.0, f64::max);
        let at = match imax.checked_sub(n * q) {
            None => "X",
            Some(0) => "sf2",
            Some(1) => "ell",
            _ => "sw2",
        };
        println!(
            "{count:>6} {:>13.6} {:>12.4} {:>10.4} {:>10.4} {:>10.4e} {:>10.4e} {:>8.4} {:>9.2e} {:>9.2e} {:>5}",
            e.info.value,
            e.info.likelihood,
            e.info.dynamics,
            e.info.connectivity,
            h.rbf_variance / var_y,
            e.info.white_variance_used / var_y,
            rms_x,
            gmax,
            gx,
            at
        );
    });
    match result {
        Ok(f) => println!(
            "done in {:.1} s: stages {:?}, {} iterations, {} evaluations, {:?}, E = {:.6}, measures {:?}; sf2/varY = {:.4e}, sw2 used/varY = {:.4e}, ell = {}",
            start.elapsed().as_secs_f64(),
            f.stage_iterations,
            f.info.iterations,
            f.info.evaluations,
            f.info.reason,
            f.last.value,
            f.info.measures,
            f.hyper.rbf_variance / var_y,
            f.last.white_variance_used / var_y,
            f.hyper.lengthscale
        ),
        Err(e) => println!("failed: {e}"),
    }
}
