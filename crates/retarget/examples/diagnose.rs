//! Exploration: one draw of protocol A's semi-supervised fit, taken apart.
//!   cargo run --release -p reprise-retarget --example diagnose -- FRAMES ZIP LANDMARKS LABELS SEED
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use reprise_numerics::gplvm::{Hyper, LikelihoodConfig};
use reprise_numerics::lbfgs::LbfgsOptions;
use reprise_retarget::baselines::{gpr, Ridge};
use reprise_retarget::shared::{fit, initial_latents, predictor, SharedObjective, Space};
use reprise_retarget::source::{Noise, SourceGp};
use reprise_retarget::{align, lle};

fn norm(v: &[f64], d: usize) -> (Vec<f64>, Vec<f64>, f64) {
    let n = (v.len() / d) as f64;
    let mean: Vec<f64> = (0..d).map(|j| v.chunks_exact(d).map(|r| r[j]).sum::<f64>() / n).collect();
    let var =
        (0..d).map(|j| v.chunks_exact(d).map(|r| (r[j] - mean[j]).powi(2)).sum::<f64>() / n).fold(0.0f64, f64::max);
    let s = var.sqrt();
    (
        v.chunks_exact(d).flat_map(|r| r.iter().zip(&mean).map(|(a, m)| (a - m) / s).collect::<Vec<_>>()).collect(),
        mean,
        s,
    )
}
fn rows(v: &[f64], d: usize, idx: &[usize]) -> Vec<f64> {
    idx.iter().flat_map(|&r| v[r * d..(r + 1) * d].iter().copied()).collect()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let frames = reprise_artifact::frames::Frames::read(std::path::Path::new(&a[1])).unwrap();
    let face = reprise_blendshape::Blendshapes::read_zip(std::path::Path::new(&a[2])).unwrap();
    let lm: Vec<usize> =
        std::fs::read_to_string(&a[3]).unwrap().lines().filter_map(|l| l.trim().parse().ok()).collect();
    let l: usize = a[4].parse().unwrap();
    let seed: u64 = a[5].parse().unwrap();
    let env = |k: &str| std::env::var(k).ok();
    let q: usize = env("RT_Q").and_then(|v| v.parse().ok()).unwrap_or(8);
    let iters: usize = env("RT_ITERS").and_then(|v| v.parse().ok()).unwrap_or(300);
    let (n, dy, dx) = (frames.rows(), face.names.len(), 3 * lm.len());
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut gauss = move || {
        let (u1, u2): (f64, f64) = (rand::Rng::gen(&mut rng), rand::Rng::gen(&mut rng));
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let mut mesh = vec![0.0; 3 * face.vertex_count()];
    let mut x = Vec::new();
    let mut xc = Vec::new();
    for r in 0..n {
        face.evaluate(frames.row(r), &mut mesh);
        for &v in &lm {
            for k in 0..3 {
                x.push(mesh[3 * v + k] + 1e-3 * gauss());
                xc.push(mesh[3 * v + k]);
            }
        }
    }
    let y = frames.values.as_slice();
    let (nx, _, sx) = norm(&x, dx);
    let (ny, ym, sy) = norm(y, dy);
    let train: Vec<usize> = (0..n * 70 / 100).collect();
    let test: Vec<usize> = (n * 75 / 100..n).collect();
    {
        let (nxc, _, _) = norm(&xc, dx);
        let tr = |v: &[f64], d: usize| rows(v, d, &train);
        let overlap = |a: &[Vec<usize>], b: &[Vec<usize>]| {
            a.iter()
                .zip(b)
                .map(|(p, q)| p.iter().filter(|i| q.contains(i)).count() as f64 / p.len().max(1) as f64)
                .sum::<f64>()
                / a.len() as f64
        };
        let knn = |v: &[f64], d: usize| -> Vec<Vec<usize>> {
            let m = v.len() / d;
            (0..m)
                .map(|i| {
                    let mut o: Vec<(f64, usize)> = (0..m)
                        .filter(|&j| j != i)
                        .map(|j| {
                            (
                                v[i * d..(i + 1) * d]
                                    .iter()
                                    .zip(&v[j * d..(j + 1) * d])
                                    .map(|(a, b)| (a - b) * (a - b))
                                    .sum::<f64>(),
                                j,
                            )
                        })
                        .collect();
                    o.sort_by(|a, b| a.0.total_cmp(&b.0));
                    o.iter().take(8).map(|p| p.1).collect()
                })
                .collect()
        };
        let (gx, gxc, gy) = (knn(&tr(&nx, dx), dx), knn(&tr(&nxc, dx), dx), knn(&tr(&ny, dy), dy));
        let tot = |v: &[f64], d: usize| {
            (0..d)
                .map(|j| {
                    let c: Vec<f64> = v.chunks_exact(d).map(|r| r[j]).collect();
                    let m = c.iter().sum::<f64>() / c.len() as f64;
                    c.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / c.len() as f64
                })
                .sum::<f64>()
        };
        println!("8-NN overlap over train: X(noisy)~Y {:.2}, X(clean)~Y {:.2}, X(noisy)~X(clean) {:.2}; total variance X noisy {:.2} clean {:.2} (noise {:.2})",
            overlap(&gx, &gy), overlap(&gxc, &gy), overlap(&gx, &gxc), tot(&nx, dx), tot(&nxc, dx), dx as f64 * (1e-3 / sx).powi(2));
    }
    let mut pool = train.clone();
    pool.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let u = 100;
    let (lab, so, to) = (&pool[..l], &pool[l..l + u], &pool[l + u..l + 2 * u]);
    let rmsw = |pred: &[f64], idx: &[usize]| {
        let t = rows(y, dy, idx);
        let sq: f64 = pred
            .chunks_exact(dy)
            .flat_map(|r| r.iter().zip(&ym).map(|(a, m)| a * sy + m).collect::<Vec<_>>())
            .zip(&t)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        (sq / t.len() as f64).sqrt()
    };
    let xl = rows(&nx, dx, lab);
    let yl = rows(&ny, dy, lab);
    let g = gpr(&xl, dx, &yl, dy).unwrap();
    let gp_on = |idx: &[usize]| -> Vec<f64> {
        let xt = rows(&nx, dx, idx);
        let mut o = vec![0.0; idx.len() * dy];
        for (xx, oo) in xt.chunks_exact(dx).zip(o.chunks_exact_mut(dy)) {
            g.mean(xx, oo);
        }
        o
    };
    let r = Ridge::fit(&xl, dx, &yl, dy, 1e-3).unwrap();
    let ridge_on =
        |idx: &[usize]| -> Vec<f64> { rows(&nx, dx, idx).chunks_exact(dx).flat_map(|xx| r.predict(xx)).collect() };
    println!("scale x {sx:.4} y {sy:.4}; GPR hyper {:?}", g.hyper());
    println!("GPR   test {:.4}  src-only {:.4}", rmsw(&gp_on(&test), &test), rmsw(&gp_on(so), so));
    println!("ridge test {:.4}  src-only {:.4}", rmsw(&ridge_on(&test), &test), rmsw(&ridge_on(so), so));
    // All of train labelled: the floor.
    let gall = gpr(&rows(&nx, dx, &train), dx, &rows(&ny, dy, &train), dy).unwrap();
    let mut o = vec![0.0; test.len() * dy];
    for (xx, oo) in rows(&nx, dx, &test).chunks_exact(dx).zip(o.chunks_exact_mut(dy)) {
        gall.mean(xx, oo);
    }
    println!("GPR on all {} train: test {:.4}", train.len(), rmsw(&o, &test));
    for (name, s, t, use_lle, init) in [
        ("sGPLVM pca", &[][..], &[][..], false, "pca"),
        ("sGPLVM align", &[][..], &[][..], false, "align"),
        ("semi pca", so, to, false, "pca"),
        ("semi align", so, to, false, "align"),
        ("semi+lle pca", so, to, true, "pca"),
        ("semi+lle align", so, to, true, "align"),
        ("semi oracle", so, to, false, "oracle"),
        ("semi oracle-fixZ", so, to, false, "oracle-fix"),
        ("semi+lle oracle", so, to, true, "oracle"),
        ("semi+lle orc-fixZ", so, to, true, "oracle-fix"),
    ] {
        let nn = l + s.len() + t.len();
        let x_rows: Vec<usize> = (0..l + s.len()).collect();
        let y_rows: Vec<usize> = (0..l).chain(l + s.len()..nn).collect();
        let xs = [xl.clone(), rows(&nx, dx, s)].concat();
        let ys = [yl.clone(), rows(&ny, dy, t)].concat();
        let src = Space { data: &xs, dim: dx, rows: x_rows.clone() };
        let tgt = Space { data: &ys, dim: dy, rows: y_rows.clone() };
        let qq = q.min(l + s.len() - 1);
        let k = 8.min(x_rows.len() - 1).min(y_rows.len() - 1);
        let prior = if use_lle {
            let wx = lle::weights(&xs, dx, k).unwrap();
            let wy = lle::weights(&ys, dy, k).unwrap();
            Some(lle::prior_matrix(&[(&wx, &x_rows), (&wy, &y_rows)], nn))
        } else if env("RT_GPRIOR").as_deref() == Some("1") {
            Some(faer::Mat::identity(nn, nn))
        } else {
            None
        };
        let mut obj =
            SharedObjective::new(&[src.clone(), tgt.clone()], nn, qq, prior, LikelihoodConfig::default()).unwrap();
        let mut start = if init == "pca" {
            initial_latents(&src, &tgt, nn, qq).unwrap()
        } else if init.starts_with("oracle") {
            // The true targets of every row, at their principal coordinates.
            let all: Vec<usize> = lab.iter().chain(s).chain(t).copied().collect();
            let truth = rows(&ny, dy, &all);
            let sp = Space { data: &truth, dim: dy, rows: (0..nn).collect() };
            initial_latents(&sp, &sp, nn, qq).unwrap()
        } else {
            align::align(&[src.clone(), tgt.clone()], nn, qq, k).unwrap()
        };
        start.extend([0.0, 0.0, (1e-2f64).ln(), 0.0, 0.0, (1e-2f64).ln()]);
        // The start's alignment: each source-only row's nearest target-owned latent's pose.
        let mut nn_pred = vec![0.0; s.len() * dy];
        for i in 0..s.len() {
            let zi = &start[(l + i) * qq..(l + i + 1) * qq];
            let d2 = |r: usize| start[r * qq..(r + 1) * qq].iter().zip(zi).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            let (j, _) = y_rows.iter().enumerate().min_by(|a, b| d2(*a.1).total_cmp(&d2(*b.1))).unwrap();
            nn_pred[i * dy..(i + 1) * dy].copy_from_slice(&ys[j * dy..(j + 1) * dy]);
        }
        if !s.is_empty() {
            print!("[start 1-NN {:.4}] ", rmsw(&nn_pred, s));
        }
        let mut gr = vec![0.0; obj.len()];
        let e0 = obj.evaluate(&start, &mut gr).unwrap();
        let (p, info) = if init == "oracle-fix" {
            let nz = nn * qq;
            let r = reprise_numerics::lbfgs::lbfgs(
                |h, g| {
                    let mut full = start.clone();
                    full[nz..].copy_from_slice(h);
                    let mut gg = vec![0.0; full.len()];
                    match obj.evaluate(&full, &mut gg) {
                        Ok(v) => {
                            g.copy_from_slice(&gg[nz..]);
                            v
                        }
                        Err(_) => {
                            g.fill(0.0);
                            f64::INFINITY
                        }
                    }
                },
                &start[nz..],
                &LbfgsOptions { max_iters: iters, ..LbfgsOptions::default() },
            );
            let mut full = start.clone();
            full[nz..].copy_from_slice(&r.x);
            (full, r.info)
        } else {
            fit(&mut obj, &start, &LbfgsOptions { max_iters: iters, ..LbfgsOptions::default() })
        };
        let e1 = obj.evaluate(&p, &mut gr).unwrap();
        let hy = |k: usize| {
            let h = nn * qq + 3 * k;
            Hyper::from_log([p[h], p[h + 1], p[h + 2]])
        };
        let z = &p[..nn * qq];
        let tp = predictor(&tgt, z, qq, hy(1)).unwrap();
        let sgp = SourceGp::new(&src, z, qq, hy(0)).unwrap();
        // Transductive: target mean at source-only rows' latents.
        let mut trans = vec![0.0; s.len() * dy];
        for (i, o) in trans.chunks_exact_mut(dy).enumerate() {
            tp.mean(&z[(l + i) * qq..(l + i + 1) * qq], o);
        }
        // Test: nearest latent, and full solves.
        let xt = rows(&nx, dx, &test);
        let mut near_pred = vec![0.0; test.len() * dy];
        let mut solve_pred = vec![0.0; test.len() * dy];
        let mut solve_nt = vec![0.0; test.len() * dy];
        let noise = Noise { capture: 1e-3 / sx, temporal: 1e-3 / sx };
        let mut prev: Option<Vec<f64>> = None;
        let mut zsum = 0.0;
        for (i, xx) in xt.chunks_exact(dx).enumerate() {
            let d2 = |r: usize| xs[r * dx..(r + 1) * dx].iter().zip(xx).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            let near = x_rows.iter().copied().min_by(|&a, &b| d2(a).total_cmp(&d2(b))).unwrap();
            let zn = &z[near * qq..(near + 1) * qq];
            tp.mean(zn, &mut near_pred[i * dy..(i + 1) * dy]);
            let st = [xx, zn].concat();
            let f = sgp.solve(&st, xx, &vec![true; dx], prev.as_deref(), noise);
            tp.mean(&f.z, &mut solve_pred[i * dy..(i + 1) * dy]);
            zsum += f.variance;
            let f2 = sgp.solve(&st, xx, &vec![true; dx], None, noise);
            tp.mean(&f2.z, &mut solve_nt[i * dy..(i + 1) * dy]);
            prev = Some(f.x);
        }
        let zn: f64 = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
        println!("{name:15} E {e0:.0}->{e1:.0} it {:?} | X {:.3?} Y {:.3?} |z| {zn:.2} | trans {:.4} near {:.4} solve {:.4} no-temporal {:.4} mean σp² {:.4}",
            info.iterations, hy(0).to_log().map(f64::exp), hy(1).to_log().map(f64::exp),
            rmsw(&trans, s), rmsw(&near_pred, &test), rmsw(&solve_pred, &test), rmsw(&solve_nt, &test), zsum / test.len() as f64);
    }
}
