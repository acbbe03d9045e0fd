//! The plain GPLVM objective against GPy 1.15 (an independent implementation) on the
//! 600 × 40 reference problem of `../shared/bench/gpy_ref`, from the fixture copied into
//! `tests/fixtures/gpy_pca_init/` (see its README).

use std::path::{Path, PathBuf};

use reprise_numerics::gplvm::{
    ConnectivityParams, ConnectivityPrior, DynamicsParams, DynamicsPrior, Hyper, Jitter, Likelihood, LikelihoodConfig,
    Objective,
};
use reprise_numerics::scg::{scg, ScgOptions};

fn fixture_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/gpy_pca_init")
}

/// A numeric CSV with a header: (header, rows).
fn read_csv(name: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let path = fixture_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines.next().expect("header").split(',').map(str::to_owned).collect();
    let rows = lines
        .filter(|l| !l.is_empty())
        .enumerate()
        .map(|(i, l)| {
            l.split(',')
                .map(|v| v.parse::<f64>().unwrap_or_else(|e| panic!("{name} row {}: {v:?}: {e}", i + 2)))
                .collect()
        })
        .collect();
    (header, rows)
}

struct Reference {
    y: Vec<f64>,
    segment: Vec<i64>,
    x: Vec<f64>,
    grad_x: Vec<f64>,
    grad_x_nojitter: Vec<f64>,
    grad_x_scale: Vec<f64>,
    scalars: std::collections::HashMap<String, f64>,
}

const N: usize = 600;
const D: usize = 40;
const Q: usize = 3;

fn load() -> Reference {
    let (header, rows) = read_csv("Y.csv");
    assert_eq!((header.len(), rows.len()), (D + 1, N));
    let y = rows.iter().flat_map(|r| r[..D].to_vec()).collect();
    let segment = rows.iter().map(|r| r[D] as i64).collect();
    let (_, rows) = read_csv("X_init_pca.csv");
    let x = rows.iter().flat_map(|r| r.clone()).collect();
    let (_, rows) = read_csv("grad_x.csv");
    let grad_x = rows.iter().flat_map(|r| r[0..3].to_vec()).collect();
    let grad_x_nojitter = rows.iter().flat_map(|r| r[3..6].to_vec()).collect();
    let grad_x_scale = rows.iter().flat_map(|r| r[6..9].to_vec()).collect();
    let text = std::fs::read_to_string(fixture_dir().join("scalars.csv")).unwrap();
    let scalars = text
        .lines()
        .skip(1)
        .map(|l| {
            let (k, v) = l.split_once(',').unwrap();
            (k.to_owned(), v.parse().unwrap())
        })
        .collect();
    Reference { y, segment, x, grad_x, grad_x_nojitter, grad_x_scale, scalars }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Compares one evaluation with GPy's; returns the worst relative errors
/// (value, hyperparameter gradients, X gradient norm-wise) and asserts them.
fn compare(jitter: Jitter, prefix: &str) -> [f64; 4] {
    let r = load();
    let s = |k: &str| r.scalars[&format!("{prefix}{k}")];
    let hyper = Hyper {
        rbf_variance: r.scalars["rbf_variance"],
        lengthscale: r.scalars["lengthscale"],
        white_variance: r.scalars["white_variance"],
    };
    let config = LikelihoodConfig { jitter, ..Default::default() };
    let mut lik = Likelihood::new(&r.y, D, Q, config).unwrap();
    let mut gx = vec![0.0; N * Q];
    let ev = lik.evaluate(&r.x, &hyper, &mut gx).unwrap();
    assert_eq!(ev.jitter.retries, 0);
    assert_eq!(ev.jitter.added, jitter.base);
    let e_value = rel(ev.value, s("nll"));
    let nat = ev.grad_hyper.to_array();
    let log = ev.grad_hyper_log(&hyper).to_array();
    let mut e_hyper: f64 = 0.0;
    for (i, name) in ["rbf_variance", "lengthscale", "white_variance"].iter().enumerate() {
        e_hyper = e_hyper.max(rel(nat[i], s(&format!("grad_{name}"))));
        if prefix.is_empty() {
            e_hyper = e_hyper.max(rel(log[i], r.scalars[&format!("grad_log_{name}")]));
        }
    }
    let want = if prefix.is_empty() { &r.grad_x } else { &r.grad_x_nojitter };
    let max_ref = want.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let e_x = gx.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / max_ref;
    // Entry-wise, with the reference's own rule: |g − g_ref| ≤ 1e-8 |g_ref| + 1e-12 scale.
    let mut e_entry: f64 = 0.0;
    for ((a, b), sc) in gx.iter().zip(want).zip(&r.grad_x_scale) {
        e_entry = e_entry.max((a - b).abs() / (1e-8 * b.abs() + 1e-12 * sc));
    }
    eprintln!(
        "GPy {}: value {e_value:.1e}, hyper grads {e_hyper:.1e}, X grad (norm-wise) {e_x:.1e}, X grad entry-wise / tolerance {e_entry:.1e}",
        if prefix.is_empty() { "with jitter 1e-8" } else { "without jitter" }
    );
    assert!(e_value < 1e-8, "value {} vs {}", ev.value, s("nll"));
    assert!(e_hyper < 1e-8, "hyperparameter gradient {nat:?}");
    assert!(e_x < 1e-8, "X gradient");
    assert!(e_entry <= 1.0, "X gradient entry-wise");
    [e_value, e_hyper, e_x, e_entry]
}

/// At GPy's PCA initialisation (σ_f² = ℓ = σ_w² = 1) with GPy's fixed 1e-8 jitter, the
/// negative log likelihood and every gradient (X; each hyperparameter, natural and log)
/// equal GPy's to 1e-8 relative. The errors are also well below the effect of the jitter
/// itself (4.8e-9 relative on the value, 1e-8 on ∂/∂σ_w²), so the jitter convention is
/// checked, not just tolerated.
#[test]
fn matches_gpy_with_jitter() {
    let [e_value, e_hyper, _, _] =
        compare(Jitter { base: 1e-8, retry_relative: 1e-6, growth: 10.0, max_retries: 0 }, "");
    assert!(e_value < 4.8e-11 && e_hyper < 1e-10, "errors should be far below the jitter's effect");
}

/// The same without any jitter against GPy's `exact_no_jitter` values.
#[test]
fn matches_gpy_without_jitter() {
    let [e_value, e_hyper, _, _] = compare(Jitter::NONE, "nojitter_");
    assert!(e_value < 4.8e-11 && e_hyper < 1e-10, "errors should be far below the jitter's effect");
}

/// The fixture is a faithful copy of `../shared/bench/gpy_ref/reference/eval_pca_init.json`
/// (its `nll` and `exact_no_jitter.nll`), when that directory is present.
#[test]
fn fixture_matches_shared_reference() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/bench/gpy_ref/reference/eval_pca_init.json");
    let Ok(text) = std::fs::read_to_string(&path) else {
        assert!(std::env::var_os("CI").is_none(), "{} not found (CI is set)", path.display());
        eprintln!("SKIPPED fixture_matches_shared_reference: ../shared not found");
        return;
    };
    let number_after = |from: usize, key: &str| -> f64 {
        let at = text[from..].find(key).unwrap_or_else(|| panic!("{key} not in {}", path.display())) + from + key.len();
        let rest = text[at..].trim_start();
        let end = rest.find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c))).unwrap();
        rest[..end].parse().unwrap()
    };
    let r = load();
    assert_eq!(number_after(0, "\"nll\":"), r.scalars["nll"]);
    let nj = text.find("\"exact_no_jitter\"").expect("exact_no_jitter");
    assert_eq!(number_after(nj, "\"nll\":"), r.scalars["nojitter_nll"]);
}

/// Trustworthiness (Venna & Kaski 2001) of the embedding `x` of the points `z` with `k`
/// neighbours: $1 - \frac{2}{nk(2n-3k-1)}\sum_i\sum_{j\in U_k(i)}(r(i,j) - k)$, where
/// $U_k(i)$ are the embedding's k nearest neighbours of $i$ that are not among the true
/// ones and $r(i,j)$ the true rank of $j$. 1 = every embedded neighbourhood is a true one.
fn trustworthiness(z: &[f64], x: &[f64], dz: usize, dx: usize, k: usize) -> f64 {
    let n = z.len() / dz;
    let ranks = |p: &[f64], d: usize, i: usize| -> Vec<usize> {
        let mut o: Vec<(f64, usize)> = (0..n)
            .filter(|&j| j != i)
            .map(|j| ((0..d).map(|c| (p[i * d + c] - p[j * d + c]).powi(2)).sum::<f64>(), j))
            .collect();
        o.sort_by(|a, b| a.0.total_cmp(&b.0));
        o.into_iter().map(|(_, j)| j).collect()
    };
    let mut penalty = 0.0;
    for i in 0..n {
        let (rz, rx) = (ranks(z, dz, i), ranks(x, dx, i));
        let mut rank_z = vec![0usize; n];
        rz.iter().enumerate().for_each(|(r, &j)| rank_z[j] = r + 1);
        penalty += rx[..k].iter().map(|&j| rank_z[j]).filter(|&r| r > k).map(|r| (r - k) as f64).sum::<f64>();
    }
    1.0 - 2.0 / (n as f64 * k as f64 * (2.0 * n as f64 - 3.0 * k as f64 - 1.0)) * penalty
}

/// Share of points whose nearest other point in `x` lies in the same segment.
fn one_nn_segment_accuracy(x: &[f64], q: usize, segment: &[i64]) -> f64 {
    let n = segment.len();
    let hits = (0..n)
        .filter(|&i| {
            let j = (0..n)
                .filter(|&j| j != i)
                .min_by(|&a, &b| {
                    let d = |j: usize| (0..q).map(|c| (x[i * q + c] - x[j * q + c]).powi(2)).sum::<f64>();
                    d(a).total_cmp(&d(b))
                })
                .unwrap();
            segment[i] == segment[j]
        })
        .count();
    hits as f64 / n as f64
}

/// The true latent curve of the reference data (fixture `latent_true.csv`).
fn latent_true() -> Vec<f64> {
    let (_, rows) = read_csv("latent_true.csv");
    rows.iter().flat_map(|r| r[..3].to_vec()).collect()
}

/// method.md §4.5: from GPy's PCA start, this SCG (Netlab variant, log-space
/// hyperparameters, up to 4000 iterations with tolerances 1e-6 / 1e-7) reaches an objective at least as good as GPy's best
/// (L-BFGS-B, −34552.445; its SCG reached −34552.208), and the fitted latents keep the
/// true curve's neighbourhoods as well as the PCA start does or better (trustworthiness
/// with 10 neighbours; 1-NN segment accuracy). Then with both priors, reporting the parts.
/// About a minute in release mode.
#[test]
fn scg_fit_reaches_gpy_objective_and_recovers_the_curve() {
    let r = load();
    let z = latent_true();
    let hyper = Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 1.0 };
    let t0 = trustworthiness(&z, &r.x, 3, Q, 10);
    for priors in [false, true] {
        let lik = Likelihood::new(&r.y, D, Q, LikelihoodConfig::default()).unwrap();
        let (dynamics, connectivity) = if priors {
            // Frames are in time order within each segment; 200 frames each.
            let times: Vec<f64> = (0..N).map(|i| (i % 200) as f64).collect();
            let dp = DynamicsParams { lengthscale: 5.0, ..Default::default() };
            let cp = ConnectivityParams { weight: 1e-3, ..Default::default() };
            (
                Some(DynamicsPrior::new(&times, &r.segment, Q, dp).unwrap()),
                Some(ConnectivityPrior::new(N, Q, cp).unwrap()),
            )
        } else {
            (None, None)
        };
        let mut obj = Objective::new(lik, dynamics, connectivity).unwrap();
        let p0 = obj.layout().pack(&r.x, &hyper);
        // The plain fit runs to a tight optimum; the prior fit is only reported.
        let opts =
            ScgOptions { max_iters: if priors { 200 } else { 4000 }, xtol: 1e-6, ftol: 1e-7, ..Default::default() };
        let start = std::time::Instant::now();
        let res = scg(|p, g| obj.evaluate(p, g), &p0, &opts);
        let secs = start.elapsed().as_secs_f64();
        let mut g = vec![0.0; p0.len()];
        obj.evaluate(&res.x, &mut g);
        let info = obj.last().clone();
        let h = obj.layout().hyper(&res.x);
        let x = obj.layout().x(&res.x);
        let (t, acc) = (trustworthiness(&z, x, 3, Q, 10), one_nn_segment_accuracy(x, Q, &r.segment));
        eprintln!(
            "SCG priors={priors}: {:?} in {secs:.1} s; E = {:.3} (NLL {:.3}, dynamics {:.3}, connectivity {:.3}); {h:?}; \
             trustworthiness(10) {t:.4} (PCA start {t0:.4}); 1-NN segment accuracy {acc:.4}",
            res.info, info.value, info.likelihood, info.dynamics, info.connectivity
        );
        assert!(res.trace.windows(2).all(|w| w[1].value <= w[0].value));
        assert!(t >= t0 - 1e-3 && t > 0.95, "trustworthiness {t} (start {t0})");
        assert!(acc > 0.95, "1-NN segment accuracy {acc}");
        if !priors {
            assert!(info.likelihood <= -34552.4, "NLL {} vs GPy's best −34552.445", info.likelihood);
        }
    }
}

/// GPy's L-BFGS-B fit of the plain model from its PCA start (`fit_lbfgsb.json`).
const GPY_LBFGSB_OBJECTIVE: f64 = -34552.44;

/// GPy's L-BFGS-B wall time for that fit: from `$REPRISE_GPY_FIT` (the JSON of
/// `gplvm_ref.py --mode fit --optimizer lbfgsb`, run by bench/gplvm.sh in the same run),
/// else the recorded 32.18 s of `../shared/bench/gpy_ref/reference/fit_lbfgsb.json`.
fn gpy_fit_seconds() -> (f64, &'static str) {
    let measured = std::env::var_os("REPRISE_GPY_FIT").and_then(|p| std::fs::read_to_string(p).ok()).and_then(|t| {
        let at = t.find("\"wall_seconds\":")? + "\"wall_seconds\":".len();
        let rest = t[at..].trim_start();
        rest[..rest.find([',', '\n', '}'])?].trim().parse().ok()
    });
    measured.map_or((32.18, "recorded"), |s| (s, "this run"))
}

/// The GPy anchor (a benchmark; bench/gplvm.sh runs it): from GPy's PCA start, L-BFGS and
/// SCG (one thread, the convergence rule of crate::optim) on the plain 600 × 40 model;
/// for each, the seconds until the objective first reaches GPy's L-BFGS-B optimum
/// −34552.44, the ratio to GPy's time, and where the rule stopped it.
#[test]
#[ignore]
fn optimisers_reach_gpy_lbfgsb_objective() {
    use reprise_numerics::gplvm::Optimizer;
    use reprise_numerics::optim::Convergence;
    let r = load();
    let hyper = Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 1.0 };
    let (gpy_s, gpy_src) = gpy_fit_seconds();
    println!("GPy L-BFGS-B: {GPY_LBFGSB_OBJECTIVE} in {gpy_s:.2} s ({gpy_src})");
    println!("| optimiser | s to reach {GPY_LBFGSB_OBJECTIVE} | GPy / ours | evaluations then | stop | iterations | evaluations | s | final E |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let rule = Convergence { f_typical: (N * D) as f64, ..Default::default() };
    for opt in [Optimizer::lbfgs(rule, 10_000), Optimizer::scg(rule, 10_000)] {
        let mut obj =
            Objective::new(Likelihood::new(&r.y, D, Q, LikelihoodConfig::default()).unwrap(), None, None).unwrap();
        let p0 = obj.layout().pack(&r.x, &hyper);
        let start = std::time::Instant::now();
        let res = opt.run(|p, g| obj.evaluate(p, g), &p0);
        let secs = start.elapsed().as_secs_f64();
        let hit = res.trace.iter().find(|t| t.value <= GPY_LBFGSB_OBJECTIVE);
        let (reach, ratio, evals) = match hit {
            Some(t) => (format!("{:.2}", t.seconds), format!("{:.1}", gpy_s / t.seconds), t.evaluations.to_string()),
            None => ("not reached".into(), "-".into(), "-".into()),
        };
        println!(
            "| {} | {reach} | {ratio} | {evals} | {} | {} | {} | {secs:.2} | {:.3} |",
            opt.name(),
            res.info.reason.name(),
            res.info.iterations,
            res.info.evaluations,
            res.info.value
        );
    }
}
