//! Refinement by damped least squares on the rig's Jacobian (Holden et al. 2017, §4.3,
//! Eq. 13): from controls $y$ with positions $x = f(y)$ short of the target $x_*$,
//! $$\Delta y = (J^\top J + \lambda^2 I)^{-1} J^\top (x_* - x),\qquad J = \partial f/\partial y,$$
//! repeated until $\lVert x_* - x\rVert$ is below a tolerance or the iterations run out.
//! The same step is solved as $J^\top (J J^\top + \lambda^2 I)^{-1} (x_* - x)$ when there are
//! fewer position values than controls (the identity
//! $(J^\top J + \lambda^2 I)^{-1} J^\top = J^\top (J J^\top + \lambda^2 I)^{-1}$), so the
//! system is $\min(c, d)$ square either way; both are symmetric positive definite for
//! $\lambda > 0$ (Cholesky).
//!
//! The Jacobian is either computed by forward differences through the rig
//! ([`fd_jacobian`]: $c + 1$ poses evaluated in one batch, the cost that dominates for a
//! rig of many controls) or given (a learned one, fixed for the frame). A step that
//! raises the residual is halved, up to [`HALVINGS`] times, then the refinement stops and
//! says so; the residual is always reported, so a pose the rig cannot reach is never
//! returned as if it were reached.

use faer::prelude::Solve;
use faer::{Mat, Side};

use crate::error::{check_positive, check_table, InvrigError, Result};

/// Halvings of a step that raised the residual before the refinement gives up.
pub const HALVINGS: usize = 4;

/// A rig evaluated in batches: controls → positions.
pub trait Rig {
    /// Controls per pose, $c$.
    fn controls(&self) -> usize;
    /// Position values per pose, $d$.
    fn positions(&self) -> usize;
    /// The positions of `count` poses (`count × c` row-major): `count × d` values.
    ///
    /// # Errors
    /// Whatever the evaluator cannot do, in its words ([`InvrigError::Rig`]).
    fn evaluate(&mut self, poses: &[f64], count: usize) -> Result<Vec<f64>>;
}

/// `rig.evaluate`, checked: the right size, every value finite.
fn evaluate(rig: &mut dyn Rig, poses: &[f64], count: usize) -> Result<Vec<f64>> {
    let x = rig.evaluate(poses, count)?;
    let d = rig.positions();
    if x.len() != count * d {
        return Err(InvrigError::Rig(format!("answered {} values for {count} poses of {d}", x.len())));
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(InvrigError::Rig(format!("answered {} for pose {}, value {}", x[i], i / d, i % d)));
    }
    Ok(x)
}

/// The positions at `y` and the forward-difference Jacobian there, $d \times c$:
/// $J_{:,j} = (f(y + h e_j) - f(y))/h$ for every control `j` that is `free` (all without a
/// mask; the other columns are zero), the poses evaluated in one batch.
///
/// # Errors
/// [`InvrigError::Param`] for a step not finite and positive; a mask of the wrong length;
/// the rig's errors.
pub fn fd_jacobian(rig: &mut dyn Rig, y: &[f64], step: f64, free: Option<&[bool]>) -> Result<(Vec<f64>, Mat<f64>)> {
    check_positive("step", step)?;
    let (c, d) = (rig.controls(), rig.positions());
    check_table("controls", y, 1, c)?;
    if let Some(f) = free.filter(|f| f.len() != c) {
        return Err(InvrigError::Shape { what: "free controls", expected: c, actual: f.len() });
    }
    let columns: Vec<usize> = (0..c).filter(|&j| free.is_none_or(|f| f[j])).collect();
    let mut poses = Vec::with_capacity((columns.len() + 1) * c);
    poses.extend_from_slice(y);
    for (k, &j) in columns.iter().enumerate() {
        poses.extend_from_slice(y);
        poses[(k + 1) * c + j] += step;
    }
    let x = evaluate(rig, &poses, columns.len() + 1)?;
    let x0 = x[..d].to_vec();
    let mut jac = Mat::zeros(d, c);
    for (k, &j) in columns.iter().enumerate() {
        for i in 0..d {
            jac[(i, j)] = (x[(k + 1) * d + i] - x0[i]) / step;
        }
    }
    Ok((x0, jac))
}

/// Where each iteration's Jacobian comes from.
#[derive(Debug, Clone, Copy)]
pub enum Jacobian<'a> {
    /// Forward differences through the rig at every iterate, with this step (control units).
    Computed {
        /// $h$.
        step: f64,
    },
    /// Forward differences through the rig at the start only, then Broyden's rank-one
    /// update after every accepted step, $J \leftarrow J + (\Delta x - J\Delta y)\,\Delta y^\top /
    /// \Delta y^\top\Delta y$ (two evaluations a step instead of $c + 1$); recomputed by
    /// differences once when a step makes no progress.
    Broyden {
        /// $h$.
        step: f64,
    },
    /// A given $d \times c$ Jacobian (a learned one), the same at every iterate.
    Given(&'a Mat<f64>),
}

/// How [`refine`] iterates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineSettings {
    /// The damping $\lambda$ (position units).
    pub lambda: f64,
    /// At most this many steps.
    pub max_iters: usize,
    /// Stop once the root-mean-square point distance $\lVert x_* - x\rVert / \sqrt{d/3}$ is at
    /// most this (position units; positions are `x, y, z` per point).
    pub tolerance: f64,
}

impl Default for RefineSettings {
    fn default() -> Self {
        Self { lambda: 1e-3, max_iters: 10, tolerance: 1e-6 }
    }
}

/// Why a refinement stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The residual reached the tolerance.
    Converged,
    /// The iterations ran out.
    MaxIters,
    /// No step, even halved [`HALVINGS`] times, lowered the residual: the closest the rig
    /// gets from here (a pose it cannot reach, or a Jacobian that no longer describes it).
    NoProgress,
}

/// A refined pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    /// The controls.
    pub y: Vec<f64>,
    /// Their positions $f(y)$.
    pub x: Vec<f64>,
    /// $\lVert x_* - f(y)\rVert$ (position units).
    pub residual: f64,
    /// The residual at the start, $\lVert x_* - f(y_0)\rVert$.
    pub initial_residual: f64,
    /// Steps taken.
    pub iterations: usize,
    /// Poses the rig evaluated.
    pub evaluations: usize,
    /// Why it stopped.
    pub stop: Stop,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Broyden's update of `j` for the step `dy` that moved the positions from `x0` to `x1`.
fn broyden_update(j: &mut Mat<f64>, dy: &[f64], x0: &[f64], x1: &[f64]) {
    let dd: f64 = dy.iter().map(|v| v * v).sum();
    if dd == 0.0 {
        return;
    }
    for i in 0..j.nrows() {
        let predicted: f64 = (0..j.ncols()).map(|k| j[(i, k)] * dy[k]).sum();
        let miss = (x1[i] - x0[i]) - predicted;
        for (k, &v) in dy.iter().enumerate() {
            j[(i, k)] += miss * v / dd;
        }
    }
}

/// The damped step $\Delta y$ for the Jacobian `j` ($d \times c$) and residual `r` ($d$),
/// columns of controls not `free` held at zero.
fn damped_step(j: &Mat<f64>, r: &[f64], lambda: f64, free: Option<&[bool]>) -> Result<Vec<f64>> {
    let (d, c) = (j.nrows(), j.ncols());
    let jm = Mat::from_fn(d, c, |i, k| if free.is_none_or(|f| f[k]) { j[(i, k)] } else { 0.0 });
    let l2 = lambda * lambda;
    let singular = || InvrigError::Param { name: "lambda", value: lambda, why: "the damped system is singular" };
    if d >= c {
        // (JᵀJ + λ²I) Δy = Jᵀ r.
        let mut a = jm.transpose() * &jm;
        for k in 0..c {
            a[(k, k)] += l2;
        }
        let mut rhs = Mat::from_fn(c, 1, |k, _| (0..d).map(|i| jm[(i, k)] * r[i]).sum());
        a.llt(Side::Lower).map_err(|_| singular())?.solve_in_place(rhs.as_mut());
        Ok((0..c).map(|k| rhs[(k, 0)]).collect())
    } else {
        // (JJᵀ + λ²I) z = r, Δy = Jᵀ z.
        let mut a = &jm * jm.transpose();
        for i in 0..d {
            a[(i, i)] += l2;
        }
        let mut z = Mat::from_fn(d, 1, |i, _| r[i]);
        a.llt(Side::Lower).map_err(|_| singular())?.solve_in_place(z.as_mut());
        Ok((0..c).map(|k| (0..d).map(|i| jm[(i, k)] * z[(i, 0)]).sum()).collect())
    }
}

/// Refines controls `y0` towards the positions `target` (Eq. 13); controls whose `free`
/// entry is false are held (the paper removes controls the animators never use).
///
/// # Errors
/// Bad tables or settings ([`InvrigError::Shape`], [`InvrigError::NonFinite`],
/// [`InvrigError::Param`]); a given Jacobian of the wrong shape; the rig's errors.
pub fn refine(
    rig: &mut dyn Rig,
    target: &[f64],
    y0: &[f64],
    jacobian: Jacobian<'_>,
    free: Option<&[bool]>,
    s: &RefineSettings,
) -> Result<Refined> {
    let (c, d) = (rig.controls(), rig.positions());
    check_table("target positions", target, 1, d)?;
    check_table("controls", y0, 1, c)?;
    check_positive("lambda", s.lambda)?;
    if !(s.tolerance.is_finite() && s.tolerance >= 0.0) {
        return Err(InvrigError::Param { name: "tolerance", value: s.tolerance, why: "must be finite and >= 0" });
    }
    if let Some(f) = free.filter(|f| f.len() != c) {
        return Err(InvrigError::Shape { what: "free controls", expected: c, actual: f.len() });
    }
    if let Jacobian::Given(j) = jacobian {
        if (j.nrows(), j.ncols()) != (d, c) {
            return Err(InvrigError::Shape { what: "Jacobian", expected: d * c, actual: j.nrows() * j.ncols() });
        }
    }
    let mut y = y0.to_vec();
    let mut x = evaluate(rig, &y, 1)?;
    let mut evaluations = 1;
    let residual_of = |x: &[f64]| -> (Vec<f64>, f64) {
        let r: Vec<f64> = target.iter().zip(x).map(|(t, v)| t - v).collect();
        let n = norm(&r);
        (r, n)
    };
    let (mut r, mut residual) = residual_of(&x);
    let initial_residual = residual;
    let mut iterations = 0;
    let mut stop = Stop::MaxIters;
    let tolerance = s.tolerance * (d as f64 / 3.0).max(1.0).sqrt();
    let free_count = free.map_or(c, |f| f.iter().filter(|&&v| v).count());
    // The Jacobian carried between iterations (Broyden), and whether it is fresh from
    // differences.
    let mut carried: Option<(Mat<f64>, bool)> = None;
    while iterations < s.max_iters {
        if residual <= tolerance {
            stop = Stop::Converged;
            break;
        }
        let j: &Mat<f64> = match jacobian {
            Jacobian::Computed { step } | Jacobian::Broyden { step } if carried.is_none() => {
                let (_, jac) = fd_jacobian(rig, &y, step, free)?;
                evaluations += free_count + 1;
                &carried.insert((jac, true)).0
            }
            Jacobian::Computed { .. } | Jacobian::Broyden { .. } => &carried.as_ref().expect("set above").0,
            Jacobian::Given(j) => j,
        };
        let mut dy = damped_step(j, &r, s.lambda, free)?;
        iterations += 1;
        let mut accepted = None;
        for _ in 0..=HALVINGS {
            let trial: Vec<f64> = y.iter().zip(&dy).map(|(a, b)| a + b).collect();
            let tx = evaluate(rig, &trial, 1)?;
            evaluations += 1;
            let (tr, tn) = residual_of(&tx);
            if tn < residual {
                accepted = Some((trial, tx, tr, tn));
                break;
            }
            dy.iter_mut().for_each(|v| *v *= 0.5);
        }
        match (accepted, jacobian) {
            (Some((trial, tx, tr, tn)), _) => {
                if let (Jacobian::Broyden { .. }, Some((jm, fresh))) = (jacobian, carried.as_mut()) {
                    broyden_update(jm, &dy, &x, &tx);
                    *fresh = false;
                } else if matches!(jacobian, Jacobian::Computed { .. }) {
                    carried = None;
                }
                (y, x, r, residual) = (trial, tx, tr, tn);
            }
            // A Broyden Jacobian that has drifted: recompute it by differences once.
            (None, Jacobian::Broyden { .. }) if carried.as_ref().is_some_and(|c| !c.1) => carried = None,
            (None, _) => {
                stop = Stop::NoProgress;
                break;
            }
        }
    }
    if stop == Stop::MaxIters && residual <= tolerance {
        stop = Stop::Converged;
    }
    Ok(Refined { y, x, residual, initial_residual, iterations, evaluations, stop })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A planar two-link arm: controls (θ₁, θ₂) in radians, positions the elbow and the
    /// hand (links of length 1 and 0.8).
    struct Arm;

    fn arm(t: &[f64]) -> [f64; 4] {
        let (e0, e1) = (t[0].cos(), t[0].sin());
        let (h0, h1) = (e0 + 0.8 * (t[0] + t[1]).cos(), e1 + 0.8 * (t[0] + t[1]).sin());
        [e0, e1, h0, h1]
    }

    impl Rig for Arm {
        fn controls(&self) -> usize {
            2
        }
        fn positions(&self) -> usize {
            4
        }
        fn evaluate(&mut self, poses: &[f64], count: usize) -> Result<Vec<f64>> {
            Ok(poses.chunks_exact(2).take(count).flat_map(arm).collect())
        }
    }

    /// A linear rig $x = A y + b$ with more controls than positions (3 → 2).
    struct Linear;

    impl Rig for Linear {
        fn controls(&self) -> usize {
            3
        }
        fn positions(&self) -> usize {
            2
        }
        fn evaluate(&mut self, poses: &[f64], count: usize) -> Result<Vec<f64>> {
            Ok(poses
                .chunks_exact(3)
                .take(count)
                .flat_map(|y| [y[0] + 2.0 * y[1] - y[2] + 1.0, 0.5 * y[0] - y[2] - 2.0])
                .collect())
        }
    }

    #[test]
    fn finite_differences_match_the_analytic_jacobian() {
        let (x0, j) = fd_jacobian(&mut Linear, &[0.3, -0.2, 1.0], 1e-6, None).unwrap();
        assert!((x0[0] - (0.3 - 0.4 - 1.0 + 1.0)).abs() < 1e-12);
        let a = [[1.0, 2.0, -1.0], [0.5, 0.0, -1.0]];
        for (i, row) in a.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                assert!((j[(i, k)] - v).abs() < 1e-6, "J[{i},{k}] = {}", j[(i, k)]);
            }
        }
        // The arm: ∂hand_x/∂θ₂ = −0.8 sin(θ₁ + θ₂).
        let t = [0.4, 0.9];
        let (_, j) = fd_jacobian(&mut Arm, &t, 1e-7, None).unwrap();
        assert!((j[(2, 1)] + 0.8 * (1.3f64).sin()).abs() < 1e-5);
        assert!((j[(0, 1)]).abs() < 1e-9, "the elbow does not move with θ₂");
        // A held control's column is not evaluated: zero.
        let (_, held) = fd_jacobian(&mut Linear, &[0.3, -0.2, 1.0], 1e-6, Some(&[true, false, true])).unwrap();
        assert_eq!((held[(0, 1)], held[(1, 1)]), (0.0, 0.0));
        assert!((held[(0, 2)] + 1.0).abs() < 1e-6);
    }

    /// From a perturbed pose the computed-Jacobian refinement reaches a reachable target.
    #[test]
    fn reaches_a_reachable_pose() {
        let truth = [0.7, -1.1];
        let target = arm(&truth);
        let s = RefineSettings { lambda: 1e-3, max_iters: 30, tolerance: 1e-9 };
        let r = refine(&mut Arm, &target, &[0.4, -0.6], Jacobian::Computed { step: 1e-7 }, None, &s).unwrap();
        assert_eq!(r.stop, Stop::Converged, "{r:?}");
        assert!(r.residual <= 1e-9 && r.initial_residual > 0.1);
        assert!((r.y[0] - truth[0]).abs() < 1e-6 && (r.y[1] - truth[1]).abs() < 1e-6, "{:?}", r.y);
        assert!(r.evaluations >= 3 * r.iterations);
        // More controls than positions: the d × d form; the target is met exactly.
        let r = refine(&mut Linear, &[2.0, -1.0], &[0.0; 3], Jacobian::Computed { step: 1e-6 }, None, &s).unwrap();
        assert!(r.residual < 1e-6, "{r:?}");
    }

    /// A given (fixed) Jacobian still descends; held controls stay where they were.
    #[test]
    fn a_given_jacobian_and_held_controls() {
        let truth = [0.7, -1.1];
        let target = arm(&truth);
        let (_, j) = fd_jacobian(&mut Arm, &[0.6, -1.0], 1e-7, None).unwrap();
        let s = RefineSettings { lambda: 1e-2, max_iters: 50, tolerance: 1e-8 };
        let r = refine(&mut Arm, &target, &[0.6, -1.0], Jacobian::Given(&j), None, &s).unwrap();
        assert!(r.residual < 1e-4 && r.residual < r.initial_residual, "{r:?}");
        let held = refine(&mut Arm, &target, &[0.6, -1.0], Jacobian::Given(&j), Some(&[false, true]), &s).unwrap();
        assert_eq!(held.y[0], 0.6);
        assert!(held.residual < held.initial_residual);
    }

    /// A target beyond the arm's reach: the closest pose, its residual said, nothing NaN.
    #[test]
    fn an_unreachable_pose_reports_its_residual() {
        let target = [3.0, 0.0, 5.0, 0.0];
        let s = RefineSettings { lambda: 1e-3, max_iters: 40, tolerance: 1e-9 };
        let r = refine(&mut Arm, &target, &[0.3, 0.3], Jacobian::Computed { step: 1e-7 }, None, &s).unwrap();
        assert_ne!(r.stop, Stop::Converged);
        assert!(r.y.iter().all(|v| v.is_finite()));
        // Outstretched along x: elbow (1, 0), hand (1.8, 0); residual √(2² + 3.2²).
        assert!((r.residual - (4.0f64 + 3.2 * 3.2).sqrt()).abs() < 1e-3, "{r:?}");
    }

    #[test]
    fn bad_input_is_a_clear_error() {
        let s = RefineSettings::default();
        let c = Jacobian::Computed { step: 1e-6 };
        let e = refine(&mut Arm, &[0.0, 0.0, f64::NAN, 0.0], &[0.0, 0.0], c, None, &s).unwrap_err();
        assert_eq!(e.to_string(), "target positions: row 0, column 2 is NaN (values must be finite)");
        assert!(refine(&mut Arm, &[0.0; 3], &[0.0, 0.0], c, None, &s).is_err());
        assert!(refine(&mut Arm, &[0.0; 4], &[0.0, 0.0], c, Some(&[true]), &s).is_err());
        let wrong = Mat::<f64>::zeros(3, 2);
        assert!(refine(&mut Arm, &[0.0; 4], &[0.0, 0.0], Jacobian::Given(&wrong), None, &s).is_err());
        struct Broken;
        impl Rig for Broken {
            fn controls(&self) -> usize {
                1
            }
            fn positions(&self) -> usize {
                2
            }
            fn evaluate(&mut self, _: &[f64], _: usize) -> Result<Vec<f64>> {
                Ok(vec![0.0, f64::NAN])
            }
        }
        let e = refine(&mut Broken, &[0.0, 0.0], &[0.0], c, None, &s).unwrap_err();
        assert!(e.to_string().contains("answered NaN for pose 0, value 1"), "{e}");
    }
}
