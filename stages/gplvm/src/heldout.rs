//! The held-out check: does the GPLVM reconstruct frames it never saw better than a PCA
//! of the same dimension fitted on the same frames?
//!
//! For one label with every `K`-th frame held out (frames $i$ with $i \bmod K = \lfloor K/2\rfloor$):
//! a GPLVM is fitted on the remaining frames' PCA coordinates, each held-out frame's
//! coordinates $y$ are explained by their best latent point
//! $x^* = \arg\min_x\lVert y - \bar y - \mu(x)\rVert^2$ ([`best_latent`]), and $g(x^*)$ is
//! evaluated through the rig. The baseline is a $q$-component PCA of the training frames'
//! scaled controls: project, reconstruct, unscale. Both errors are RMS vertex distances to
//! the original frame's mesh. The label's PCA basis itself (the GPLVM's output space) was
//! fitted on all frames: the GPLVM side sees the held-out frames through that linear basis
//! only, which its error bound (the $d$-component projection) includes.

use std::collections::HashMap;

use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::pca::{self, PcaModel, SCALED};
use reprise_artifact::scales::{self, Scale};
use reprise_numerics::gplvm::{best_latent, FitConfig, LatentModel, ProjectOptions};
use reprise_numerics::pca::{Pca, PcaParams};
use reprise_rig::{PoseLayout, Rig};
use reprise_stagekit::rig::{mesh_rmse, meshes};
use reprise_stagekit::{ProgressBar, StageError, StageResult};

use crate::{fit_label, Args, LabelData};

/// What the check measured for one label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Heldout {
    pub(crate) gplvm_rmse: f64,
    pub(crate) pca_rmse: f64,
    pub(crate) frames: usize,
}

/// Everything the check needs besides the label's data.
pub(crate) struct Checker<'a> {
    labeled: &'a LabeledFrames,
    row_of: HashMap<(i64, i64), usize>,
    rig: (Box<dyn Rig>, PoseLayout),
    pcas: Vec<PcaModel>,
    scales: Vec<Scale>,
    scales_path: std::path::PathBuf,
}

impl<'a> Checker<'a> {
    pub(crate) fn open(args: &Args, labeled: &'a LabeledFrames) -> StageResult<Self> {
        let (Some(pm), Some(sc), Some(ct)) = (&args.pca_models, &args.scales, &args.controls) else {
            return Err(StageError::Config("the held-out check needs --pca-models, --scales and --controls".into()));
        };
        let (pca_controls, pcas) = pca::read_models(pm)?;
        if pca_controls != labeled.frames.controls {
            return Err(StageError::Input(format!(
                "{} and {} list different controls; rerun pca",
                pm.display(),
                args.labeled_frames.display()
            )));
        }
        let rig = reprise_stagekit::rig::open_rig(&Controls::read(ct)?, &labeled.frames.controls)?;
        let row_of =
            (0..labeled.frames.rows()).map(|r| ((labeled.segment_id[r], labeled.frames.frame[r]), r)).collect();
        Ok(Self { labeled, row_of, rig, pcas, scales: scales::read(sc)?, scales_path: sc.clone() })
    }

    fn original(&self, l: &LabelData, i: usize) -> StageResult<Vec<f64>> {
        let r = self.row_of.get(&(l.segments[i], l.frames[i])).ok_or_else(|| {
            StageError::Input(format!(
                "label `{}`: segment {} frame {} of the PCA coordinates is not in the labeled frames; rerun pca",
                l.label, l.segments[i], l.frames[i]
            ))
        })?;
        Ok(self.labeled.frames.row(*r).to_vec())
    }

    pub(crate) fn check(
        &self,
        l: &LabelData,
        config: &FitConfig,
        every: usize,
        bar: &ProgressBar,
    ) -> StageResult<Heldout> {
        let (test, train): (Vec<usize>, Vec<usize>) = (0..l.n()).partition(|i| i % every == every / 2);
        let train_data = l.subset(&train);
        let fit = fit_label(&train_data, config, bar)?;
        let pca_model = self
            .pcas
            .iter()
            .find(|p| p.label == l.label && p.variant == SCALED)
            .ok_or_else(|| StageError::Input(format!("no scaled PCA model for label `{}`", l.label)))?;
        let map =
            reprise_label_models::rig_map(pca_model, &self.labeled.frames.controls, &self.scales, &self.scales_path)?;
        let model = LatentModel::new(l.label.clone(), fit.predictor.clone(), fit.offset.clone(), map)
            .map_err(|e| StageError::Numerical(format!("label `{}`: {e}", l.label)))?;
        let d = l.d;
        let centre = |y: &[f64]| -> Vec<f64> { y.iter().zip(&fit.offset).map(|(v, m)| v - m).collect() };
        let train_y: Vec<f64> = train_data.y.chunks_exact(d).flat_map(centre).collect();
        let opts = ProjectOptions::default();
        let (mut y, mut p) = (vec![0.0; d], vec![0.0; model.controls()]);
        let mut gplvm_rows = Vec::with_capacity(test.len());
        for &i in &test {
            let found = best_latent(&fit.predictor, &centre(&l.y[i * d..(i + 1) * d]), &train_y, &opts);
            model.controls_into(&found.x, &mut y, &mut p);
            gplvm_rows.push(p.clone());
        }
        // The baseline: a q-component PCA of the training frames' scaled controls.
        let mine: Vec<&Scale> = self.scales.iter().filter(|s| s.label == l.label).collect();
        let per: Vec<&Scale> = self
            .labeled
            .frames
            .controls
            .iter()
            .map(|c| {
                mine.iter().copied().find(|s| &s.control == c).ok_or_else(|| {
                    StageError::Input(format!("{}: no scale for `{}`/`{c}`", self.scales_path.display(), l.label))
                })
            })
            .collect::<StageResult<_>>()?;
        let used: Vec<usize> = (0..per.len()).filter(|&c| per[c].used).collect();
        let scaled = |row: &[f64]| -> Vec<f64> {
            used.iter().map(|&c| per[c].weight * (row[c] - per[c].mean) + per[c].mean).collect()
        };
        let originals_train: Vec<Vec<f64>> = train.iter().map(|&i| self.original(l, i)).collect::<StageResult<_>>()?;
        let z: Vec<f64> = originals_train.iter().flat_map(|r| scaled(r)).collect();
        let q = config.q;
        let params = PcaParams { variance: 1.0, min_components: q, max_components: q };
        let pca = Pca::fit(&z, used.len(), &params)
            .map_err(|e| StageError::Numerical(format!("label `{}`: held-out PCA: {e}", l.label)))?;
        let originals: Vec<Vec<f64>> = test.iter().map(|&i| self.original(l, i)).collect::<StageResult<_>>()?;
        let pca_rows: Vec<Vec<f64>> = originals
            .iter()
            .map(|row| {
                let zr = pca.reconstruct(&pca.project(&scaled(row), q));
                let mut out: Vec<f64> = per.iter().map(|s| s.mean).collect();
                for (&c, v) in used.iter().zip(zr) {
                    out[c] = (v - per[c].mean) / per[c].weight + per[c].mean;
                }
                out
            })
            .collect();
        let truth = meshes(&self.rig, &originals)?;
        Ok(Heldout {
            gplvm_rmse: mesh_rmse(&meshes(&self.rig, &gplvm_rows)?, &truth),
            pca_rmse: mesh_rmse(&meshes(&self.rig, &pca_rows)?, &truth),
            frames: test.len(),
        })
    }
}
