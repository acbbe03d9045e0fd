//! Quick look at the corpus's scaled PCA spectra without the pipeline: per label, each
//! moving control's weight by the paper's Eq. 3 (n = ±1, ±2 at the label mean), then the
//! eigenvalues of the scaled covariance by Jacobi sweeps.
//! `cargo run --release -p reprise-dragon-face --example spectra` (the pipeline's `pca`
//! stage is the reference; this is for tuning the generator).

use reprise_dragon_face::{generate_corpus, DragonRig, TakeKind, LABELS};

fn main() {
    let rig = DragonRig::new(7);
    let t = std::time::Instant::now();
    let corpus = generate_corpus(&rig, 7);
    println!("generated in {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
    let c = rig.controls().len();
    for label in LABELS {
        let mut rows: Vec<&[f64]> = Vec::new();
        for take in corpus.takes.iter().filter(|t| t.label == label && t.kind == TakeKind::Good) {
            for f in 0..take.good_frame_count() {
                rows.push(take.frame(f));
            }
        }
        let n = rows.len();
        let mean: Vec<f64> = (0..c).map(|i| rows.iter().map(|r| r[i]).sum::<f64>() / n as f64).collect();
        let base = rig.evaluate_vec(&mean);
        let mut z = vec![0.0; n * c];
        let mut names = Vec::new();
        let mut var = vec![0.0; c];
        for i in 0..c {
            let sd = (rows.iter().map(|r| (r[i] - mean[i]).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
            if sd == 0.0 || rig.controls()[i].group == "eyes" {
                continue;
            }
            let (mut num, mut den) = (0.0, 0.0);
            for step in [-2.0, -1.0, 1.0, 2.0f64] {
                let mut p = mean.clone();
                p[i] += step * sd;
                let e = rig.evaluate_vec(&p);
                let d = e.iter().zip(&base).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
                num += step.abs() * sd * d;
                den += (step * sd).powi(2);
            }
            let w = num / den;
            for (k, r) in rows.iter().enumerate() {
                z[k * c + i] = w * (r[i] - mean[i]);
            }
            var[i] = (w * sd).powi(2);
            names.push(i);
        }
        // Covariance of the used controls (m × m); its eigenvalues are the PCA variances.
        let m = names.len();
        let mut g = vec![0.0; m * m];
        for (a, &i) in names.iter().enumerate() {
            for (b, &j) in names.iter().enumerate().take(a + 1) {
                let s: f64 = (0..n).map(|k| z[k * c + i] * z[k * c + j]).sum();
                g[a * m + b] = s;
                g[b * m + a] = s;
            }
        }
        let ev = jacobi_eigenvalues(&mut g, m);
        let total: f64 = ev.iter().sum();
        let mut cum = 0.0;
        let mut d = [0usize; 3];
        for (k, e) in ev.iter().enumerate() {
            cum += e / total;
            for (j, th) in [0.85, 0.95, 0.99].iter().enumerate() {
                if d[j] == 0 && cum >= *th {
                    d[j] = k + 1;
                }
            }
        }
        let mut top: Vec<(f64, &str)> = names.iter().map(|&i| (var[i], rig.controls()[i].name.as_str())).collect();
        top.sort_by(|a, b| b.0.total_cmp(&a.0));
        let tv: f64 = top.iter().map(|t| t.0).sum();
        let top: Vec<String> = top.iter().take(5).map(|t| format!("{} {:.2}", t.1, t.0 / tv)).collect();
        let first: Vec<String> = ev.iter().take(5).map(|e| format!("{:.2}", e / total)).collect();
        println!("{label:>10} n {n:4} d {:?} ev [{}] top: {}", d, first.join(" "), top.join(", "));
    }
}

/// Eigenvalues (descending) of a symmetric matrix by cyclic Jacobi sweeps.
fn jacobi_eigenvalues(a: &mut [f64], n: usize) -> Vec<f64> {
    for _ in 0..12 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .filter(|(i, j)| i != j)
            .map(|(i, j)| a[i * n + j].powi(2))
            .sum();
        let diag: f64 = (0..n).map(|i| a[i * n + i].powi(2)).sum();
        if off < 1e-14 * diag {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq.abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let (cs, sn) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = cs * akp - sn * akq;
                    a[k * n + q] = sn * akp + cs * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = cs * apk - sn * aqk;
                    a[q * n + k] = sn * apk + cs * aqk;
                }
            }
        }
    }
    let mut ev: Vec<f64> = (0..n).map(|i| a[i * n + i].max(0.0)).collect();
    ev.sort_by(|x, y| y.total_cmp(x));
    ev
}
