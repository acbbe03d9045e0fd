//! The held-out check: how well does a label's GPLVM reconstruct frames it never saw,
//! beside PCAs of the same training frames, and how well does it generate a frame between
//! two training frames, beside linear interpolation?
//!
//! A label's $N$ rows $i$ (its frames in coordinate order) split into the held-out rows
//! $H = \{i : i \bmod K = \lfloor K/2\rfloor\}$ and the training rows $T$. With $p_i$ the
//! frame's controls and $z_i$ its scaled controls (the pca stage's convention,
//! [`Scaling`]: $z_c = w_c(p_c - \bar p_c) + \bar p_c$ over the used controls):
//!
//! 1. **A basis that never saw $H$.** A PCA of $\{z_i : i \in T\}$ with the $d$ components of
//!    the label's shipped model (fewer, $k < d$, if the training frames span fewer):
//!    mean $\bar z_T$, unit directions $U$ ($k\times|U|$), coordinates
//!    $y_i = U(z_i - \bar z_T)$ for every row, and the rig map
//!    $g_T(y) = $ unscale$(\bar z_T + U^\top y)$ ([`Scaling::rig_map`]).
//! 2. **GPLVM.** A GPLVM fitted on $\{y_i : i \in T\}$ (the stage's configuration); each
//!    held-out $y_i$ is explained by its best latent point
//!    $x^*_i = \arg\min_x\lVert y_i - \bar y - \mu(x)\rVert^2$ ([`best_latent`]) and
//!    reconstructed as $\hat p_i = g_T(\bar y + \mu(x^*_i))$.
//! 3. **PCA-q and PCA-d.** $\hat p_i = g_T(y_i^{(m)})$, $y_i^{(m)}$ = the first $m$
//!    coordinates of $y_i$ and zeros, for $m = q$ and $m = k$: the reconstruction
//!    $\bar z_T + U_m^\top U_m(z_i - \bar z_T)$ of a PCA of the training frames with $m$
//!    components, unscaled. PCA-q has the GPLVM's dimension; PCA-d its output space.
//! 4. **Generative.** Each $i \in H$ whose previous and next frames in its segment are
//!    training rows $a, b$, with fitted latents $x_a, x_b$:
//!    $\hat p_i = g_T(\bar y + \mu(\tfrac12(x_a + x_b)))$, beside the reference without a
//!    model, $\hat p_i = \tfrac12(p_a + p_b)$ (linear interpolation of controls), and the
//!    same interpolation confined to the space the GPLVM models,
//!    $\hat p_i = g_T(\tfrac12(y_a + y_b))$, whose floor is PCA-d's as the GPLVM's is.
//!
//! Every error is the RMS vertex distance to the frames' own meshes through the rig $e$,
//! $\sqrt{\sum_i\sum_v\lVert e_v(\hat p_i) - e_v(p_i)\rVert^2 / (n V)}$ over the $n$ frames
//! of the set and $V$ vertices, in mesh units.
//!
//! Why the basis is refitted: the label's shipped PCA was fitted on all $N$ frames, and a
//! check in that basis reconstructs a held-out frame from its own $d$ coordinates there,
//! so the GPLVM's error could not exceed PCA-d's *in-sample* error; it measured PCA-d, not
//! the model. Here nothing a held-out frame reaches was fitted with it.

use std::collections::HashMap;
use std::path::PathBuf;

use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::pca::{self, PcaModel, SCALED};
use reprise_artifact::scales::{self, Scale};
use reprise_label_models::Scaling;
use reprise_numerics::gplvm::{best_latent, FitConfig, LatentModel, ProjectOptions};
use reprise_numerics::pca::{Pca, PcaParams};
use reprise_rig::{PoseLayout, Rig};
use reprise_stagekit::rig::{mesh_rmse, meshes};
use reprise_stagekit::{ProgressBar, StageError, StageResult};

use crate::{fit_label, Args, LabelData};

/// What the check measured for one label; errors in mesh units, `None` over no frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Heldout {
    /// The held-out frames through their best latent points.
    pub(crate) gplvm_rmse: Option<f64>,
    /// The held-out frames through the training basis's first q components.
    pub(crate) pca_q_rmse: Option<f64>,
    /// The held-out frames through all `d` of them.
    pub(crate) pca_d_rmse: Option<f64>,
    /// Components of the training basis ($k \le d$).
    pub(crate) d: usize,
    /// Held-out frames.
    pub(crate) frames: usize,
    /// The generative frames through the GPLVM at their neighbours' mid-latent.
    pub(crate) generative_gplvm_rmse: Option<f64>,
    /// The generative frames as their neighbours' mid-pose.
    pub(crate) generative_interp_rmse: Option<f64>,
    /// The generative frames as their neighbours' mid-coordinates in the check's basis.
    pub(crate) generative_interp_d_rmse: Option<f64>,
    /// Frames of the generative check.
    pub(crate) generative_frames: usize,
}

/// Everything the check needs besides the label's data.
pub(crate) struct Checker<'a> {
    labeled: &'a LabeledFrames,
    row_of: HashMap<(i64, i64), usize>,
    rig: (Box<dyn Rig>, PoseLayout),
    pcas: Vec<PcaModel>,
    scales: Vec<Scale>,
    scales_path: PathBuf,
}

impl<'a> Checker<'a> {
    /// Reads the PCA models, scales and rig the flags name.
    pub(crate) fn open(args: &Args, labeled: &'a LabeledFrames) -> StageResult<Self> {
        let (Some(pm), Some(sc), Some(ct)) = (&args.io.pca_models, &args.io.scales, &args.io.controls) else {
            return Err(StageError::Config("the held-out check needs --pca-models, --scales and --controls".into()));
        };
        let (pca_controls, pcas) = pca::read_models(pm)?;
        if pca_controls != labeled.frames.controls {
            return Err(StageError::Input(format!(
                "{} and {} list different controls; rerun pca",
                pm.display(),
                args.io.labeled_frames.display()
            )));
        }
        let rig = reprise_stagekit::rig::open_rig(&Controls::read(ct)?, &labeled.frames.controls)?;
        Ok(Self::new(labeled, rig, pcas, scales::read(sc)?, sc.clone()))
    }

    fn new(
        labeled: &'a LabeledFrames,
        rig: (Box<dyn Rig>, PoseLayout),
        pcas: Vec<PcaModel>,
        scales: Vec<Scale>,
        scales_path: PathBuf,
    ) -> Self {
        let row_of =
            (0..labeled.frames.rows()).map(|r| ((labeled.segment_id[r], labeled.frames.frame[r]), r)).collect();
        Self { labeled, row_of, rig, pcas, scales, scales_path }
    }

    /// The controls of row `i` of `l`, from the labeled frames.
    fn original(&self, l: &LabelData, i: usize) -> StageResult<Vec<f64>> {
        let r = self.row_of.get(&(l.segments[i], l.frames[i])).ok_or_else(|| {
            StageError::Input(format!(
                "label `{}`: segment {} frame {} of the PCA coordinates is not in the labeled frames; rerun pca",
                l.label, l.segments[i], l.frames[i]
            ))
        })?;
        Ok(self.labeled.frames.row(*r).to_vec())
    }

    /// $d$ of the label's shipped scaled PCA (which must be the coordinates' $d$).
    fn shipped_d(&self, l: &LabelData) -> StageResult<usize> {
        let model = self
            .pcas
            .iter()
            .find(|p| p.label == l.label && p.variant == SCALED)
            .ok_or_else(|| StageError::Input(format!("no scaled PCA model for label `{}`", l.label)))?;
        if model.d() != l.d {
            return Err(StageError::Input(format!(
                "label `{}`: the PCA model has {} components but the coordinates {}; rerun pca",
                l.label,
                model.d(),
                l.d
            )));
        }
        Ok(model.d())
    }

    /// RMS vertex distance of each candidate set of rows to the meshes of `truth` (table
    /// rows, in the same order), mesh units; `None` for an empty set.
    fn errors(&self, truth: &[Vec<f64>], candidates: &[&[Vec<f64>]]) -> StageResult<Vec<Option<f64>>> {
        if truth.is_empty() {
            return Ok(vec![None; candidates.len()]);
        }
        let target = meshes(&self.rig, truth)?;
        candidates.iter().map(|rows| Ok(Some(mesh_rmse(&meshes(&self.rig, rows)?, &target)))).collect()
    }

    /// The check of one label with every `every`-th row held out (see the module docs).
    pub(crate) fn check(
        &self,
        l: &LabelData,
        config: &FitConfig,
        every: usize,
        bar: &ProgressBar,
        name: &str,
    ) -> StageResult<Heldout> {
        let numerical = |what: &str, e: &dyn std::fmt::Display| {
            StageError::Numerical(format!("label `{}`: held-out check: {what}: {e}", l.label))
        };
        let d = self.shipped_d(l)?;
        let scaling = Scaling::new(&l.label, &self.labeled.frames.controls, &self.scales, &self.scales_path)?;
        let originals: Vec<Vec<f64>> = (0..l.n()).map(|i| self.original(l, i)).collect::<StageResult<_>>()?;
        let (test, train): (Vec<usize>, Vec<usize>) = (0..l.n()).partition(|i| i % every == every / 2);

        // 1. The basis of the training frames, and every frame's coordinates in it.
        let z: Vec<Vec<f64>> = originals.iter().map(|p| scaling.values(p, true).collect()).collect();
        let z_train: Vec<f64> = train.iter().flat_map(|&i| z[i].iter().copied()).collect();
        let params = PcaParams { variance: 1.0, min_components: d, max_components: d };
        let basis = Pca::fit(&z_train, scaling.used.len(), &params).map_err(|e| numerical("PCA", &e))?;
        let k = basis.kept;
        let coords = LabelData { d: k, y: z.iter().flat_map(|zi| basis.project(zi, k)).collect(), ..l.clone() };
        let y = |i: usize| &coords.y[i * k..(i + 1) * k];

        // 2. The GPLVM of the training frames, mapped to the rig through that basis.
        let train_data = coords.subset(&train);
        let fit = fit_label(&train_data, config, bar, name)?;
        let map = scaling.rig_map(&scaling.pca_model(&basis, SCALED))?;
        let model = LatentModel::new(l.label.clone(), fit.predictor.clone(), fit.x.clone(), fit.offset.clone(), map)
            .map_err(|e| numerical("model", &e))?;
        let g = |x: &[f64]| {
            let (mut y, mut p) = (vec![0.0; k], vec![0.0; model.controls()]);
            model.controls_into(x, &mut y, &mut p);
            p
        };
        let centre = |y: &[f64]| -> Vec<f64> { y.iter().zip(&fit.offset).map(|(v, m)| v - m).collect() };
        let train_y: Vec<f64> = train_data.y.chunks_exact(k).flat_map(centre).collect();
        let opts = ProjectOptions::default();
        let gplvm_rows: Vec<Vec<f64>> =
            test.iter().map(|&i| g(&best_latent(&fit.predictor, &centre(y(i)), &fit.x, &train_y, &opts).x)).collect();

        // 3. PCA with m components: the first m coordinates through the same map.
        let pca_rows = |m: usize| -> Vec<Vec<f64>> {
            test.iter()
                .map(|&i| {
                    let mut ym = y(i).to_vec();
                    ym[m.min(k)..].fill(0.0);
                    let mut p = vec![0.0; model.controls()];
                    model.map.apply(&ym, &mut p);
                    p
                })
                .collect()
        };
        let truth: Vec<Vec<f64>> = test.iter().map(|&i| originals[i].clone()).collect();
        let held = self.errors(&truth, &[&gplvm_rows, &pca_rows(config.q), &pca_rows(k)])?;

        // 4. Generative: held-out frames between two training frames of their segment.
        let q = config.q;
        let row_of: HashMap<(i64, i64), usize> = (0..l.n()).map(|i| ((l.segments[i], l.frames[i]), i)).collect();
        let mut train_pos = vec![None; l.n()];
        train.iter().enumerate().for_each(|(j, &i)| train_pos[i] = Some(j));
        let neighbour = |i: usize, step: i64| row_of.get(&(l.segments[i], l.frames[i] + step)).copied();
        // (held-out row, its neighbours' rows, their positions among the training rows)
        let between: Vec<(usize, [usize; 2], [usize; 2])> = test
            .iter()
            .filter_map(|&i| {
                let (a, b) = (neighbour(i, -1)?, neighbour(i, 1)?);
                Some((i, [a, b], [train_pos[a]?, train_pos[b]?]))
            })
            .collect();
        let latent = |j: usize| &fit.x[j * q..(j + 1) * q];
        let mid = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(u, v)| 0.5 * (u + v)).collect() };
        let gen_gplvm: Vec<Vec<f64>> =
            between.iter().map(|(_, _, [ja, jb])| g(&mid(latent(*ja), latent(*jb)))).collect();
        let gen_interp: Vec<Vec<f64>> =
            between.iter().map(|(_, [a, b], _)| mid(&originals[*a], &originals[*b])).collect();
        let gen_interp_d: Vec<Vec<f64>> = between
            .iter()
            .map(|(_, [a, b], _)| {
                let mut p = vec![0.0; model.controls()];
                model.map.apply(&mid(y(*a), y(*b)), &mut p);
                p
            })
            .collect();
        let gen_truth: Vec<Vec<f64>> = between.iter().map(|(i, _, _)| originals[*i].clone()).collect();
        let generative = self.errors(&gen_truth, &[&gen_gplvm, &gen_interp, &gen_interp_d])?;

        Ok(Heldout {
            gplvm_rmse: held[0],
            pca_q_rmse: held[1],
            pca_d_rmse: held[2],
            d: k,
            frames: test.len(),
            generative_gplvm_rmse: generative[0],
            generative_interp_rmse: generative[1],
            generative_interp_d_rmse: generative[2],
            generative_frames: between.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;
    use reprise_artifact::frames::Frames;
    use reprise_rig::RigError;

    use super::*;

    /// A rig whose mesh is its controls: vertex $v$ at $(p_{3v}, p_{3v+1}, p_{3v+2})$, so
    /// a frame's mesh error is $\lVert\Delta p\rVert/\sqrt V$ with $V = C/3$.
    struct Identity(Vec<String>);

    impl Rig for Identity {
        fn describe(&self) -> String {
            "identity".into()
        }
        fn control_names(&self) -> &[String] {
            &self.0
        }
        fn rest_pose(&self) -> Vec<f64> {
            vec![0.0; self.0.len()]
        }
        fn vertex_count(&self) -> usize {
            self.0.len() / 3
        }
        fn triangles(&self) -> &[[u32; 3]] {
            &[]
        }
        fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError> {
            out.copy_from_slice(poses);
            Ok(())
        }
    }

    /// One label `l` whose segments are `poses` (segment, frame, control; the control
    /// count a multiple of 3), with scales of weight 1 about the controls' means, the
    /// shipped PCA of all its frames with `d` components (the held-out frames included, as
    /// the pca stage fits it) and its coordinates.
    struct World {
        labeled: LabeledFrames,
        scales: Vec<Scale>,
        shipped: Pca,
        label: LabelData,
    }

    fn world(poses: &[Vec<Vec<f64>>], d: usize) -> World {
        let c = poses[0][0].len();
        let controls: Vec<String> = (0..c).map(|j| format!("c{j}")).collect();
        let (mut segment_id, mut frame, mut times) = (vec![], vec![], vec![]);
        for (s, seg) in poses.iter().enumerate() {
            for t in 0..seg.len() {
                segment_id.push(s as i64);
                frame.push(10 + 100 * s as i64 + t as i64);
                times.push(t as f64 / 24.0);
            }
        }
        let values: Vec<f64> = poses.iter().flatten().flatten().copied().collect();
        let n = frame.len();
        let scales: Vec<Scale> = (0..c)
            .map(|j| Scale {
                label: "l".into(),
                control: controls[j].clone(),
                mean: (0..n).map(|r| values[r * c + j]).sum::<f64>() / n as f64,
                std: 1.0,
                weight: 1.0,
                residual: 0.0,
                used: true,
                reason: String::new(),
            })
            .collect();
        let scaling = Scaling::new("l", &controls, &scales, "scales.parquet".as_ref()).unwrap();
        let z: Vec<f64> = values.chunks(c).flat_map(|p| scaling.values(p, true).collect::<Vec<_>>()).collect();
        let shipped = Pca::fit(&z, c, &PcaParams { variance: 1.0, min_components: d, max_components: d }).unwrap();
        assert_eq!(shipped.kept, d, "the data spans d dimensions");
        let label = LabelData {
            label: "l".into(),
            d,
            y: z.chunks(c).flat_map(|zi| shipped.project(zi, d)).collect(),
            times,
            segments: segment_id.clone(),
            clips: vec!["clip".into(); n],
            frames: frame.clone(),
        };
        let frames = Frames { fps: 24.0, controls, clip: vec!["clip".into(); n], frame, time: vec![0.0; n], values };
        let labeled = LabeledFrames { segment_id, label: vec!["l".into(); n], frames, masked_controls: vec![] };
        World { labeled, scales, shipped, label }
    }

    impl World {
        /// The check with latent dimension `q`, every `every`-th frame held out.
        fn check(&self, q: usize, every: usize) -> Heldout {
            let names = self.labeled.frames.controls.clone();
            let layout = PoseLayout::new(&names, vec![0.0; names.len()], &names).unwrap();
            let scaling = Scaling::new("l", &names, &self.scales, "scales.parquet".as_ref()).unwrap();
            let model = scaling.pca_model(&self.shipped, SCALED);
            let checker = Checker::new(
                &self.labeled,
                (Box::new(Identity(names)), layout),
                vec![model],
                self.scales.clone(),
                "scales.parquet".into(),
            );
            let q = q.to_string();
            let files = ["--coords", "c", "--labeled-frames", "f", "--latents", "l", "--models", "m", "--trace", "t"];
            let flags = ["--fits", "s", "--q", &q, "--max-iters", "400"];
            let args = Args::try_parse_from(["reprise-gplvm"].into_iter().chain(files).chain(flags)).unwrap();
            checker.check(&self.label, &args.fit_config(), every, &ProgressBar::hidden(), "test").unwrap()
        }
    }

    /// `m + Σ_k a_k u_k` in 6 controls.
    fn pose(m: &[f64; 6], terms: &[(f64, [f64; 6])]) -> Vec<f64> {
        (0..6).map(|j| m[j] + terms.iter().map(|(a, u)| a * u[j]).sum::<f64>()).collect()
    }

    const M: [f64; 6] = [0.5, -1.0, 2.0, 0.0, 1.5, -0.5];
    const U1: [f64; 6] = [1.0, 0.5, 0.0, -0.5, 0.2, 0.0];
    const U2: [f64; 6] = [0.0, 1.0, -1.0, 0.3, 0.4, 0.0];
    const U3: [f64; 6] = [0.2, 0.0, 0.5, 1.0, -0.3, 0.0];

    /// Frames on a q-dimensional plane (two segments, smooth non-linear curves on it):
    /// the training frames span the plane, so PCA-q (= PCA-d, d = q here) reconstructs a
    /// held-out frame exactly; the GPLVM models the same plane.
    #[test]
    fn a_plane_is_reconstructed_exactly_by_pca_q() {
        let seg = |s: f64, n: usize| -> Vec<Vec<f64>> {
            (0..n)
                .map(|t| {
                    let t = t as f64;
                    pose(&M, &[((0.2 * t + s).sin() * 2.0, U1), ((0.13 * t).cos() * (1.0 + s), U2)])
                })
                .collect()
        };
        let w = world(&[seg(0.0, 40), seg(1.0, 40)], 2);
        let h = w.check(2, 5);
        assert_eq!((h.d, h.frames), (2, 16));
        let (q, d, g) = (h.pca_q_rmse.unwrap(), h.pca_d_rmse.unwrap(), h.gplvm_rmse.unwrap());
        assert!(q < 1e-9 && d < 1e-9, "PCA-q {q}, PCA-d {d}");
        assert!(g.is_finite() && g < 0.05, "GPLVM {g}");
    }

    /// The leak is gone. The training frames span three directions; every held-out frame
    /// adds `a` along a fourth, u₄, that no training frame has. The shipped PCA (all frames,
    /// d = 4) reconstructs those frames exactly: the old check, in that basis, could not
    /// see the error. The basis of the training frames has 3 components, and every
    /// reconstruction in it misses u₄ entirely: each error is at least a/√V.
    #[test]
    fn a_direction_only_held_out_frames_have_is_not_reconstructed() {
        let (a, every) = (0.8, 5);
        let u4 = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]; // orthogonal to U1, U2, U3
        let frames: Vec<Vec<f64>> = (0..60)
            .map(|i| {
                let t = i as f64;
                let extra = if i % every == every / 2 { a } else { 0.0 };
                pose(&M, &[((0.2 * t).sin(), U1), ((0.11 * t).cos(), U2), ((0.07 * t).sin() * 0.5, U3), (extra, u4)])
            })
            .collect();
        let w = world(std::slice::from_ref(&frames), 4);
        // Weight 1: the scaled controls are the controls.
        for (i, z) in frames.iter().enumerate().filter(|(i, _)| i % every == every / 2) {
            let back = w.shipped.reconstruct(&w.shipped.project(z, 4));
            let err = back.iter().zip(z).map(|(b, z)| (b - z).powi(2)).sum::<f64>().sqrt();
            assert!(err < 1e-9, "frame {i}: the all-frames basis reconstructs it ({err})");
        }
        let h = w.check(2, every);
        assert_eq!((h.d, h.frames), (3, 12));
        let floor = a / 2f64.sqrt() * (1.0 - 1e-9);
        for (what, e) in [("GPLVM", h.gplvm_rmse), ("PCA-q", h.pca_q_rmse), ("PCA-d", h.pca_d_rmse)] {
            let e = e.unwrap();
            assert!(e >= floor, "{what}: {e} < a/√V = {floor}");
        }
        // PCA-d misses exactly the u₄ component (the rest lies in the training span).
        assert!((h.pca_d_rmse.unwrap() - a / 2f64.sqrt()).abs() < 1e-9);
    }

    /// Motion linear in time within each segment: the midpoint of a frame's two
    /// neighbours is the frame, so the interpolation reference is exact; held-out frames
    /// at a segment's end (no next frame in it) are not counted.
    #[test]
    fn linear_motion_is_interpolated_exactly() {
        let seg = |m: [f64; 6], v: [f64; 6], n: usize| -> Vec<Vec<f64>> {
            (0..n).map(|t| pose(&m, &[(t as f64 * 0.1, v)])).collect()
        };
        let m2 = [1.0, 0.0, 1.0, 0.5, -0.5, 0.0];
        let w = world(&[seg(M, U1, 33), seg(m2, U2, 30)], 3);
        let h = w.check(2, 5);
        // Held out: rows 2, 7, …, 32 (32 = the last of segment 0) and 37, …, 62 (the last of segment 1).
        assert_eq!((h.frames, h.generative_frames), (13, 11));
        let interp = h.generative_interp_rmse.unwrap();
        assert!(interp < 1e-12, "interpolation {interp}");
        // The two segments span 3 dimensions, all in the basis: interpolating there is exact too.
        let interp_d = h.generative_interp_d_rmse.unwrap();
        assert!(interp_d < 1e-9, "interpolation in PCA-d {interp_d}");
        // The model is not exact here (q = 2 < d = 3), but smooth in time: its midpoint
        // frame is nearer than one frame's motion (the smaller segment's, mesh RMS).
        let step = |u: &[f64; 6]| 0.1 * (u.iter().map(|v| v * v).sum::<f64>() / 2.0).sqrt();
        let g = h.generative_gplvm_rmse.unwrap();
        assert!(g < step(&U1).min(step(&U2)), "GPLVM {g}");
    }
}
