//! A fitted inverse rig mapping and the ways of applying it (Holden et al. 2017, Table 1):
//! the nearest training pose, the regression, and the regression refined on a learned or
//! computed Jacobian; plus the computed-Jacobian refinement from the rest pose (their
//! Fig. 11: without the learned start it drifts).

use faer::Mat;

use crate::error::{check_table, InvrigError, Result};
use crate::gpr::{gather, Gpr};
use crate::refine::{fd_jacobian, refine, Jacobian, RefineSettings, Rig, Stop};
use crate::subsample::{subsample, SubsampleSettings};

/// How a pose's controls are found from its positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// The controls of the training pose nearest in position space.
    Nearest,
    /// The regression alone (Eq. 1–6).
    Gpr,
    /// The regression, refined on the Jacobian the second regression predicts (§4.4).
    GprLearnedJacobian,
    /// The regression, refined on finite-difference Jacobians through the rig (Eq. 13).
    GprComputedJacobian,
    /// The regression, refined on one finite-difference Jacobian kept current by Broyden's
    /// updates (not in the paper: for rigs of many controls, where each Jacobian costs
    /// $c + 1$ evaluations).
    GprBroydenJacobian,
    /// The rest pose, refined on finite-difference Jacobians (no learned start).
    RestComputedJacobian,
}

impl Method {
    /// Every method, in the order of the paper's table.
    pub const ALL: [Method; 6] = [
        Method::Nearest,
        Method::Gpr,
        Method::GprLearnedJacobian,
        Method::GprComputedJacobian,
        Method::GprBroydenJacobian,
        Method::RestComputedJacobian,
    ];

    /// The name used in flags and tables.
    pub fn name(self) -> &'static str {
        match self {
            Method::Nearest => "nearest",
            Method::Gpr => "gpr",
            Method::GprLearnedJacobian => "gpr-learned-jacobian",
            Method::GprComputedJacobian => "gpr-computed-jacobian",
            Method::GprBroydenJacobian => "gpr-broyden-jacobian",
            Method::RestComputedJacobian => "rest-computed-jacobian",
        }
    }

    /// The method of a name.
    pub fn parse(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Whether it needs the learned Jacobian.
    pub fn learns_jacobian(self) -> bool {
        self == Method::GprLearnedJacobian
    }
}

/// Training poses: `n` rows of `d` position values (`x`) and of `c` controls (`y`).
#[derive(Debug, Clone, PartialEq)]
pub struct Training {
    /// Positions, `n × d` row-major.
    pub x: Vec<f64>,
    /// Position values per pose.
    pub d: usize,
    /// Controls, `n × c` row-major.
    pub y: Vec<f64>,
    /// Controls per pose.
    pub c: usize,
}

/// The training set and the regressions fitted on it.
#[derive(Debug, Clone)]
pub struct InverseMap {
    x: Vec<f64>,
    y: Vec<f64>,
    d: usize,
    c: usize,
    gpr: Gpr,
    free: Vec<bool>,
    rest: Vec<f64>,
    learned: Option<Gpr>,
}

/// A pose's controls, and what finding them took.
#[derive(Debug, Clone, PartialEq)]
pub struct Solved {
    /// The controls.
    pub y: Vec<f64>,
    /// Refinement steps taken (0 without refinement).
    pub iterations: usize,
    /// Rig evaluations made (0 without refinement).
    pub evaluations: usize,
    /// Why the refinement stopped; `None` without refinement.
    pub stop: Option<Stop>,
}

impl InverseMap {
    /// Fits the regression on the training poses with $(\theta_0, \theta_1)$ = `theta`;
    /// `free` marks the controls the refinement may move, `rest` is the rig's rest pose.
    ///
    /// # Errors
    /// As [`Gpr::fit`]; a `free` or `rest` of the wrong length.
    pub fn new(training: Training, theta: (f64, f64), free: Vec<bool>, rest: Vec<f64>) -> Result<Self> {
        let Training { x, d, y, c } = training;
        let gpr = Gpr::fit(&x, d, &y, c, theta.0, theta.1)?;
        if free.len() != c {
            return Err(InvrigError::Shape { what: "free controls", expected: c, actual: free.len() });
        }
        check_table("rest pose", &rest, 1, c)?;
        Ok(Self { x, y, d, c, gpr, free, rest, learned: None })
    }

    /// Training poses.
    pub fn len(&self) -> usize {
        self.gpr.len()
    }

    /// Whether it has no training poses (never).
    pub fn is_empty(&self) -> bool {
        self.gpr.is_empty()
    }

    /// Controls free to move.
    pub fn free_count(&self) -> usize {
        self.free.iter().filter(|&&f| f).count()
    }

    /// Values the learned Jacobian stores per training pose it is learned from: the pose's
    /// $d \times$ free Jacobian and the regression's weights for it.
    pub fn learned_jacobian_values_per_pose(&self) -> usize {
        2 * self.d * self.free_count()
    }

    /// Fits the second regression, positions → the rig's Jacobian on the free controls,
    /// from finite-difference Jacobians at training poses (§4.4): all of them if their
    /// Jacobians fit in `max_values` values, else as many as fit, spread over the training
    /// positions by farthest points from the first pose. Returns the poses used.
    ///
    /// # Errors
    /// [`InvrigError::Param`] when not even one pose fits; the rig's errors; as [`Gpr::fit`].
    pub fn learn_jacobian(&mut self, rig: &mut dyn Rig, step: f64, max_values: usize) -> Result<usize> {
        let per_pose = self.learned_jacobian_values_per_pose().max(1);
        let k = (max_values / per_pose).min(self.len());
        if k == 0 {
            return Err(InvrigError::Param {
                name: "learned Jacobian values",
                value: max_values as f64,
                why: "not enough for the Jacobian of one pose",
            });
        }
        let poses: Vec<usize> = if k == self.len() {
            (0..k).collect()
        } else {
            let s = SubsampleSettings { farthest: k - 1, total: k, batch: 1, theta0: 1.0, theta1: 1.0 };
            subsample(&self.x, self.d, &self.y, self.c, 0, &s)?
        };
        let free_cols: Vec<usize> = (0..self.c).filter(|&j| self.free[j]).collect();
        let width = self.d * free_cols.len();
        let mut flat = Vec::with_capacity(k * width);
        for &p in &poses {
            let (_, j) = fd_jacobian(rig, &self.y[p * self.c..(p + 1) * self.c], step, Some(&self.free))?;
            for i in 0..self.d {
                flat.extend(free_cols.iter().map(|&col| j[(i, col)]));
            }
        }
        let x = gather(&self.x, self.d, &poses);
        self.learned = Some(Gpr::fit(&x, self.d, &flat, width, self.gpr.theta0(), self.gpr.theta1())?);
        Ok(k)
    }

    /// The controls of the training pose nearest to `target` in position space.
    pub fn nearest(&self, target: &[f64]) -> Vec<f64> {
        let d2 = |a: &[f64]| a.iter().zip(target).map(|(u, v)| (u - v) * (u - v)).sum::<f64>();
        let best = self
            .x
            .chunks_exact(self.d)
            .enumerate()
            .min_by(|a, b| d2(a.1).total_cmp(&d2(b.1)).then(a.0.cmp(&b.0)))
            .map_or(0, |(i, _)| i);
        self.y[best * self.c..(best + 1) * self.c].to_vec()
    }

    /// The learned Jacobian at `target`, $d \times c$ (zero on held controls).
    ///
    /// # Errors
    /// [`InvrigError::Param`] when [`InverseMap::learn_jacobian`] has not run.
    pub fn learned_jacobian(&self, target: &[f64]) -> Result<Mat<f64>> {
        let learned = self.learned.as_ref().ok_or(InvrigError::Param {
            name: "learned Jacobian",
            value: 0.0,
            why: "not fitted: call learn_jacobian first",
        })?;
        let flat = learned.predict(target)?;
        let free_cols: Vec<usize> = (0..self.c).filter(|&j| self.free[j]).collect();
        let f = free_cols.len();
        let mut j = Mat::zeros(self.d, self.c);
        for i in 0..self.d {
            for (k, &col) in free_cols.iter().enumerate() {
                j[(i, col)] = flat[i * f + k];
            }
        }
        Ok(j)
    }

    /// The controls for the positions `target` by `method`; refinements evaluate `rig`.
    ///
    /// # Errors
    /// A target of the wrong size or not finite; the rig's errors; the learned Jacobian
    /// missing for [`Method::GprLearnedJacobian`].
    pub fn solve(
        &self,
        method: Method,
        target: &[f64],
        rig: &mut dyn Rig,
        step: f64,
        settings: &RefineSettings,
    ) -> Result<Solved> {
        check_table("target positions", target, 1, self.d)?;
        let plain = |y: Vec<f64>| Solved { y, iterations: 0, evaluations: 0, stop: None };
        let refined = |start: &[f64], jacobian: Jacobian<'_>, rig: &mut dyn Rig| -> Result<Solved> {
            let r = refine(rig, target, start, jacobian, Some(&self.free), settings)?;
            Ok(Solved { y: r.y, iterations: r.iterations, evaluations: r.evaluations, stop: Some(r.stop) })
        };
        match method {
            Method::Nearest => Ok(plain(self.nearest(target))),
            Method::Gpr => Ok(plain(self.gpr.predict(target)?)),
            Method::GprLearnedJacobian => {
                let j = self.learned_jacobian(target)?;
                refined(&self.gpr.predict(target)?, Jacobian::Given(&j), rig)
            }
            Method::GprComputedJacobian => refined(&self.gpr.predict(target)?, Jacobian::Computed { step }, rig),
            Method::GprBroydenJacobian => refined(&self.gpr.predict(target)?, Jacobian::Broyden { step }, rig),
            Method::RestComputedJacobian => refined(&self.rest, Jacobian::Computed { step }, rig),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A planar two-link arm: controls (θ₁, θ₂, unused) in radians, positions the elbow
    /// and the hand (links 1 and 0.8).
    struct Arm;

    fn arm(t: &[f64]) -> [f64; 4] {
        let (e0, e1) = (t[0].cos(), t[0].sin());
        [e0, e1, e0 + 0.8 * (t[0] + t[1]).cos(), e1 + 0.8 * (t[0] + t[1]).sin()]
    }

    impl Rig for Arm {
        fn controls(&self) -> usize {
            3
        }
        fn positions(&self) -> usize {
            4
        }
        fn evaluate(&mut self, poses: &[f64], count: usize) -> Result<Vec<f64>> {
            Ok(poses.chunks_exact(3).take(count).flat_map(arm).collect())
        }
    }

    /// Training poses on a grid of the arm's reach; the third control never moves.
    fn trained() -> InverseMap {
        let mut y = Vec::new();
        for a in 0..8 {
            for b in 0..8 {
                y.extend([0.2 + 0.15 * f64::from(a), 0.3 + 0.15 * f64::from(b), 0.0]);
            }
        }
        let x: Vec<f64> = y.chunks_exact(3).flat_map(arm).collect();
        let mut m =
            InverseMap::new(Training { x, d: 4, y, c: 3 }, (0.5, 1e-8), vec![true, true, false], vec![0.0; 3]).unwrap();
        assert_eq!(m.learn_jacobian(&mut Arm, 1e-7, usize::MAX).unwrap(), 64);
        m
    }

    fn joint_error(y: &[f64], target: &[f64]) -> f64 {
        arm(y).iter().zip(target).map(|(a, b)| (a - b) * (a - b)).sum()
    }

    #[test]
    fn each_refinement_improves_on_its_start_and_the_regression_on_the_nearest_pose() {
        let m = trained();
        let s = RefineSettings { lambda: 1e-3, max_iters: 20, tolerance: 1e-10 };
        // Between grid poses.
        let truth = [0.71, 0.93, 0.0];
        let target = arm(&truth);
        let err = |method| {
            let r = m.solve(method, &target, &mut Arm, 1e-7, &s).unwrap();
            assert_eq!(r.y[2], 0.0, "{method:?} moved a held control");
            joint_error(&r.y, &target)
        };
        let (nn, gpr, learned, computed, broyden) = (
            err(Method::Nearest),
            err(Method::Gpr),
            err(Method::GprLearnedJacobian),
            err(Method::GprComputedJacobian),
            err(Method::GprBroydenJacobian),
        );
        assert!(gpr < 0.1 * nn, "regression {gpr} vs nearest {nn}");
        assert!(learned < gpr, "learned {learned} vs regression {gpr}");
        assert!(computed < 1e-12, "computed {computed}");
        assert!(broyden < 1e-12, "Broyden {broyden}");
        let evals = |method| m.solve(method, &target, &mut Arm, 1e-7, &s).unwrap().evaluations;
        assert!(
            evals(Method::GprBroydenJacobian) < evals(Method::GprComputedJacobian),
            "Broyden's updates save evaluations"
        );
        // The learned Jacobian is close to the true one between samples.
        let (_, truth_j) = fd_jacobian(&mut Arm, &truth, 1e-7, Some(&[true, true, false])).unwrap();
        let learned_j = m.learned_jacobian(&target).unwrap();
        let diff = (&learned_j - &truth_j).norm_l2() / truth_j.norm_l2();
        assert!(diff < 0.05, "learned Jacobian off by {diff}");
    }

    #[test]
    fn from_rest_the_refinement_can_land_in_the_other_elbow() {
        // Rest is θ = 0; the target bends the elbow the other way (θ₂ < 0 is the mirror
        // solution of the same hand, not of the same elbow): the refinement from rest
        // reaches a local answer no better than the one from the regression.
        let m = trained();
        let s = RefineSettings { lambda: 1e-3, max_iters: 20, tolerance: 1e-10 };
        let target = arm(&[1.2, 1.1, 0.0]);
        let from_gpr = m.solve(Method::GprComputedJacobian, &target, &mut Arm, 1e-7, &s).unwrap();
        let from_rest = m.solve(Method::RestComputedJacobian, &target, &mut Arm, 1e-7, &s).unwrap();
        assert!(from_gpr.iterations < from_rest.iterations || from_rest.stop != Some(Stop::Converged));
        assert!(joint_error(&from_gpr.y, &target) <= joint_error(&from_rest.y, &target) + 1e-12);
    }

    #[test]
    fn names_round_trip_and_the_learned_jacobian_is_required() {
        for m in Method::ALL {
            assert_eq!(Method::parse(m.name()), Some(m));
        }
        let y = vec![0.0, 0.0, 0.0, 0.5, 0.5, 0.0];
        let x: Vec<f64> = y.chunks_exact(3).flat_map(arm).collect();
        let m = InverseMap::new(Training { x, d: 4, y, c: 3 }, (0.5, 1e-8), vec![true; 3], vec![0.0; 3]).unwrap();
        let err =
            m.solve(Method::GprLearnedJacobian, &arm(&[0.2, 0.2, 0.0]), &mut Arm, 1e-7, &RefineSettings::default());
        assert!(matches!(err, Err(InvrigError::Param { .. })));
        assert_eq!(m.learned_jacobian_values_per_pose(), 2 * 4 * 3);
        // A memory bound takes as many poses as fit, farthest first; none fitting is an error.
        let mut m = trained();
        assert_eq!(m.learn_jacobian(&mut Arm, 1e-7, 10 * 2 * 4 * 2 + 5).unwrap(), 10);
        assert!(m.learned_jacobian(&arm(&[0.7, 0.9, 0.0])).is_ok());
        assert!(m.learn_jacobian(&mut Arm, 1e-7, 15).is_err());
    }
}
