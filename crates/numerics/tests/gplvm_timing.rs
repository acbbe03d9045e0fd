//! Timings of the GPLVM objective (a benchmark, not a timed test): run with
//! `bench/gplvm.sh`, which also times GPy in the same run, or alone with
//! `cargo test --release -p reprise-numerics --test gplvm_timing -- --ignored --nocapture`.
//!
//! For N = 200, 400, 800, 1600 (D = 40, q = 3), single thread unless stated: the objective and
//! gradient plain (likelihood only) and with both priors; each prior alone; and the
//! "O(N³) floor" — a faer Cholesky plus the SPD inverse from it, which any exact gradient
//! needs (GPy's reference measures dpotrf + dpotri the same way). With
//! `REPRISE_GPY_TIMING` naming the JSON of `gplvm_ref.py --mode timing` (one thread), the
//! table adds GPy's time and the ratios GPy / reprise and reprise / floor at each N.

use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt;
use faer::{Mat, Par};
use rand::{Rng, SeedableRng};
use reprise_numerics::gplvm::{
    ConnectivityParams, ConnectivityPrior, DynamicsParams, DynamicsPrior, Hyper, Likelihood, LikelihoodConfig,
    Objective,
};

/// Median wall time in ms of `reps` runs after one warm-up.
fn median_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

fn problem(n: usize, d: usize, q: usize) -> (Vec<f64>, Vec<f64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(n as u64);
    let x: Vec<f64> = (0..n * q).map(|_| rng.gen_range(-2.0..2.0)).collect();
    let y: Vec<f64> = (0..n * d).map(|_| rng.gen_range(-1.0..1.0)).collect();
    (x, y)
}

fn objective(n: usize, y: &[f64], priors: bool, par: Par) -> Objective {
    let (d, q) = (40, 3);
    let lik = Likelihood::new(y, d, q, LikelihoodConfig { par, ..Default::default() }).unwrap();
    if !priors {
        return Objective::new(lik, None, None).unwrap();
    }
    let times: Vec<f64> = (0..n).map(|i| (i % 100) as f64).collect();
    let seg: Vec<usize> = (0..n).map(|i| i / 100).collect();
    let dp = DynamicsPrior::new(&times, &seg, q, DynamicsParams::default()).unwrap();
    let cp = ConnectivityPrior::new(n, q, ConnectivityParams { par, ..Default::default() }).unwrap();
    Objective::new(lik, Some(dp), Some(cp)).unwrap()
}

/// (N, GPy's median objective+gradient in ms at D = 40) from `$REPRISE_GPY_TIMING`.
fn gpy_times() -> Vec<(usize, f64)> {
    let Some(path) = std::env::var_os("REPRISE_GPY_TIMING") else {
        println!("(GPy not timed: REPRISE_GPY_TIMING is not set; bench/gplvm.sh sets it)");
        return vec![];
    };
    let Ok(text) = std::fs::read_to_string(&path) else {
        println!("(GPy not timed: {} unreadable)", std::path::Path::new(&path).display());
        return vec![];
    };
    // Rows look like {"N": 800, "D": 40, "gpy_eval_median_s": 0.0787, ...}.
    let num = |row: &str, key: &str| -> Option<f64> {
        let at = row.find(&format!("\"{key}\": "))? + key.len() + 4;
        let rest = &row[at..];
        rest[..rest.find([',', '}', '\n'])?].trim().parse().ok()
    };
    text.split('{')
        .filter_map(|row| Some((num(row, "N")? as usize, num(row, "D")?, num(row, "gpy_eval_median_s")?)))
        .filter(|(_, d, _)| *d == 40.0)
        .map(|(n, _, s)| (n, s * 1e3))
        .collect()
}

#[test]
#[ignore]
fn timing_table() {
    let (d, q) = (40, 3);
    let hyper = Hyper { rbf_variance: 1.0, lengthscale: 1.0, white_variance: 0.1 };
    let gpy = gpy_times();
    println!(
        "| N | objective+grad plain (ms) | with both priors (ms) | connectivity alone (ms) | dynamics alone (ms) \
         | Cholesky + inverse (ms) | plain / floor | GPy plain (ms) | GPy / plain | plain, Par::rayon(2) (ms) \
         | both priors, Par::rayon(2) (ms) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for n in [200, 400, 800, 1600] {
        let reps = if n >= 1600 {
            3
        } else if n >= 800 {
            7
        } else {
            11
        };
        let (x, y) = problem(n, d, q);
        let mut plain = objective(n, &y, false, Par::Seq);
        let p = plain.layout().pack(&x, &hyper);
        let mut g = vec![0.0; p.len()];
        let t_plain = median_ms(reps, || {
            plain.evaluate(&p, &mut g);
        });
        assert!(plain.last().error.is_none());
        let mut full = objective(n, &y, true, Par::Seq);
        let t_full = median_ms(reps, || {
            full.evaluate(&p, &mut g);
        });
        assert!(full.last().error.is_none());
        let mut conn = ConnectivityPrior::new(n, q, ConnectivityParams::default()).unwrap();
        let mut gx = vec![0.0; n * q];
        let t_conn = median_ms(reps, || {
            conn.value_grad_add(&x, &mut gx).unwrap();
        });
        let times: Vec<f64> = (0..n).map(|i| (i % 100) as f64).collect();
        let seg: Vec<usize> = (0..n).map(|i| i / 100).collect();
        let mut dynp = DynamicsPrior::new(&times, &seg, q, DynamicsParams::default()).unwrap();
        let t_dyn = median_ms(reps, || {
            dynp.value_grad_add(&x, &mut gx).unwrap();
        });
        // The O(N³) floor: Cholesky + SPD inverse of a well-conditioned kernel matrix.
        let k = Mat::<f64>::from_fn(n, n, |i, j| {
            let d2: f64 = (0..q).map(|c| (x[i * q + c] - x[j * q + c]).powi(2)).sum();
            (-0.5 * d2).exp() + if i == j { 0.1 } else { 0.0 }
        });
        let mut l = Mat::<f64>::zeros(n, n);
        let mut inv = Mat::<f64>::zeros(n, n);
        let mut mem = MemBuffer::new(StackReq::any_of(&[
            llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default()),
            llt::inverse::inverse_scratch::<f64>(n, Par::Seq),
        ]));
        let t_floor = median_ms(reps, || {
            l.copy_from(&k);
            llt::factor::cholesky_in_place(
                l.as_mut(),
                Default::default(),
                Par::Seq,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .unwrap();
            llt::inverse::inverse(inv.as_mut(), l.as_ref(), Par::Seq, MemStack::new(&mut mem));
        });
        let mut par2 = objective(n, &y, false, Par::rayon(2));
        let t_par = median_ms(reps, || {
            par2.evaluate(&p, &mut g);
        });
        let mut full2 = objective(n, &y, true, Par::rayon(2));
        let t_full2 = median_ms(reps, || {
            full2.evaluate(&p, &mut g);
        });
        let (g, ratio) = match gpy.iter().find(|(gn, _)| *gn == n) {
            Some((_, ms)) => (format!("{ms:.2}"), format!("{:.2}", ms / t_plain)),
            None => ("-".into(), "-".into()),
        };
        println!(
            "| {n} | {t_plain:.2} | {t_full:.2} | {t_conn:.2} | {t_dyn:.3} | {t_floor:.2} | {:.2} | {g} | {ratio} | {t_par:.2} | {t_full2:.2} |",
            t_plain / t_floor
        );
    }
}

/// `segments` smooth random curves of `len` frames in 3-D (sums of three sinusoids per
/// coordinate, unit scale): latents shaped like a fitted label's, with times and ids.
fn trajectories(segments: usize, len: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<i64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut x = Vec::with_capacity(segments * len * 3);
    for _ in 0..segments {
        let waves: Vec<[f64; 3]> =
            (0..9).map(|_| [rng.gen_range(0.5..3.0), rng.gen_range(0.0..6.3), rng.gen_range(0.2..1.0)]).collect();
        for t in 0..len {
            let s = t as f64 / len as f64;
            for k in 0..3 {
                x.push(waves[3 * k..3 * k + 3].iter().map(|[f, ph, a]| a * (f * 6.3 * s + ph).sin()).sum::<f64>());
            }
        }
    }
    let times = (0..segments * len).map(|i| (i % len) as f64).collect();
    let segs = (0..segments * len).map(|i| (i / len) as i64).collect();
    (x, times, segs)
}

/// The connectivity prior's paths per evaluation (value and gradient, one thread) at
/// N = 200 … 1600 on smooth trajectories of 100 frames: the exact path against the coarse
/// graph of runs of 2 and 3 frames and the subset of every other frame, as times, the
/// ratio exact / path, and each path's error against the exact prior: relative value
/// error, relative gradient error ‖g − g_exact‖/‖g_exact‖ and the gradient's direction
/// cosine (see connectivity.rs).
#[test]
#[ignore]
fn connectivity_paths() {
    use reprise_numerics::gplvm::{coarse_groups, subset_rows};
    let q = 3;
    let paths = ["coarse 2", "coarse 3", "subset 2"];
    println!(
        "| N | exact (ms) |{}",
        paths
            .iter()
            .map(|p| format!(" {p} (ms) | exact / {p} | value err. | gradient err. | cosine |"))
            .collect::<String>()
    );
    println!("|---|---|{}", "---|---|---|---|---|".repeat(paths.len()));
    for n in [200, 400, 800, 1600] {
        let reps = if n >= 1600 { 3 } else { 7 };
        let (x, times, segs) = trajectories(n / 100, 100, n as u64);
        let params = ConnectivityParams::default();
        let mut exact = ConnectivityPrior::new(n, q, params).unwrap();
        let mut g_exact = vec![0.0; n * q];
        let v_exact = exact.value_grad_add(&x, &mut g_exact).unwrap().value;
        let mut gx = vec![0.0; n * q];
        let t_exact = median_ms(reps, || {
            exact.value_grad_add(&x, &mut gx).unwrap();
        });
        let mut row = format!("| {n} | {t_exact:.1} |");
        for path in paths {
            let mut prior = match path {
                "coarse 2" => ConnectivityPrior::coarse(coarse_groups(&times, &segs, 2), q, params),
                "coarse 3" => ConnectivityPrior::coarse(coarse_groups(&times, &segs, 3), q, params),
                _ => ConnectivityPrior::on_subset(n, subset_rows(&times, &segs, 2), q, params),
            }
            .unwrap();
            let mut g = vec![0.0; n * q];
            let v = prior.value_grad_add(&x, &mut g).unwrap().value;
            let t = median_ms(reps, || {
                prior.value_grad_add(&x, &mut gx).unwrap();
            });
            let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
            let diff: Vec<f64> = g.iter().zip(&g_exact).map(|(a, b)| a - b).collect();
            let cos = g.iter().zip(&g_exact).map(|(a, b)| a * b).sum::<f64>() / (norm(&g) * norm(&g_exact));
            row += &format!(
                " {t:.2} | {:.1} | {:.2e} | {:.2} | {cos:.3} |",
                t_exact / t,
                (v - v_exact).abs() / v_exact.abs(),
                norm(&diff) / norm(&g_exact)
            );
        }
        println!("{row}");
    }
}
