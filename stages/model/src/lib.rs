//! The label models that the stages after `gplvm` (bridges, synthesize, evaluate) use:
//! each label's GPLVM ([`reprise_artifact::gplvm`]), its scaled PCA
//! ([`reprise_artifact::pca`]) and its control scaling ([`reprise_artifact::scales`]),
//! assembled into a [`LatentModel`] that maps a latent point to rig controls.
#![warn(missing_docs)]

use std::path::Path;

use reprise_artifact::gplvm::{self, GplvmModel};
use reprise_artifact::pca::{self, PcaModel, SCALED};
use reprise_artifact::scales::{self, Scale};
use reprise_numerics::gplvm::{Hyper, Jitter, LatentModel, LikelihoodConfig, MeanPredictor, Predictor, RigMap};
use reprise_stagekit::{StageError, StageResult};

pub use reprise_numerics::gplvm::LatentModel as Model;

/// Every label's model, over one list of controls (the columns of `labeled_frames`).
#[derive(Debug, Clone)]
pub struct Models {
    /// Control names, in the order of every model's output.
    pub controls: Vec<String>,
    /// One model per label, in the order of the GPLVM artifact.
    pub models: Vec<LatentModel>,
}

impl Models {
    /// The model of `label`.
    pub fn get(&self, label: &str) -> Option<&LatentModel> {
        self.models.iter().find(|m| m.label == label)
    }

    /// The model of `label`, or an error listing the labels there are.
    pub fn require(&self, label: &str) -> StageResult<&LatentModel> {
        self.get(label).ok_or_else(|| {
            let known: Vec<&str> = self.models.iter().map(|m| m.label.as_str()).collect();
            StageError::Input(format!("no model for label `{label}`; the models are: {}", known.join(", ")))
        })
    }
}

/// The map from a label's scaled-PCA coordinates to its rig controls.
pub fn rig_map(pca: &PcaModel, controls: &[String], scales: &[Scale], scales_path: &Path) -> StageResult<RigMap> {
    let (mut mean_p, mut weight) = (Vec::with_capacity(controls.len()), Vec::with_capacity(controls.len()));
    for c in controls {
        let s = scales.iter().find(|s| s.label == pca.label && &s.control == c).ok_or_else(|| {
            StageError::Input(format!(
                "{}: no scale for label `{}`, control `{c}`; rerun scale",
                scales_path.display(),
                pca.label
            ))
        })?;
        mean_p.push(s.mean);
        weight.push(if s.used { s.weight } else { 0.0 });
    }
    RigMap::from_pca(&pca.mean, &pca.directions, &mean_p, &weight)
        .map_err(|e| StageError::Input(format!("label `{}`: {e}", pca.label)))
}

fn assemble(
    g: &GplvmModel,
    pca: &PcaModel,
    controls: &[String],
    scales: &[Scale],
    paths: [&Path; 3],
) -> StageResult<LatentModel> {
    if pca.d() != g.d {
        return Err(StageError::Input(format!(
            "label `{}`: {} has d = {} but {} has {} components; rerun gplvm",
            g.label,
            paths[0].display(),
            g.d,
            paths[1].display(),
            pca.d()
        )));
    }
    // Refactor K exactly as the fit did: the white variance it used, the jitter it added.
    let hyper =
        Hyper { rbf_variance: g.rbf_variance, lengthscale: g.lengthscale, white_variance: g.white_variance_used };
    let config = LikelihoodConfig {
        jitter: Jitter { base: g.jitter, max_retries: 0, ..Jitter::GPY },
        white_floor: 0.0,
        ..Default::default()
    };
    let bad = |e: reprise_numerics::gplvm::GplvmError| {
        StageError::Input(format!("{}: label `{}`: {e}", paths[0].display(), g.label))
    };
    let mean = MeanPredictor::from_parts(g.x.clone(), g.kinv_y.clone(), g.q, g.d, hyper).map_err(bad)?;
    let predictor = Predictor::from_mean(mean, &config).map_err(bad)?;
    let map = rig_map(pca, controls, scales, paths[2])?;
    LatentModel::new(g.label.clone(), predictor, g.offset.clone(), map).map_err(bad)
}

/// Loads every label's model from the `gplvm_models`, `pca_models` and `scales` artifacts.
pub fn load(gplvm_models: &Path, pca_models: &Path, scales_path: &Path) -> StageResult<Models> {
    let stored = gplvm::read_models(gplvm_models)?;
    let (controls, pcas) = pca::read_models(pca_models)?;
    let scale_rows = scales::read(scales_path)?;
    let models = stored
        .iter()
        .map(|g| {
            let pca = pcas.iter().find(|p| p.label == g.label && p.variant == SCALED).ok_or_else(|| {
                StageError::Input(format!("{}: no scaled PCA for label `{}`", pca_models.display(), g.label))
            })?;
            assemble(g, pca, &controls, &scale_rows, [gplvm_models, pca_models, scales_path])
        })
        .collect::<StageResult<Vec<_>>>()?;
    Ok(Models { controls, models })
}
