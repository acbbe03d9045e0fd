//! The label models that the stages after `gplvm` (bridges, synthesize, evaluate) use:
//! each label's GPLVM ([`reprise_artifact::gplvm`]), its scaled PCA
//! ([`reprise_artifact::pca`]) and its control scaling ([`reprise_artifact::scales`]),
//! assembled into a [`LatentModel`] that maps a latent point to rig controls; and the
//! control scaling itself ([`Scaling`]), which the pca stage fits in and the gplvm
//! stage's held-out check refits in.
#![warn(missing_docs)]

mod scaling;

use std::path::Path;

use reprise_artifact::gplvm::{self, GplvmModel};
use reprise_artifact::pca::{self, PcaModel, SCALED};
use reprise_artifact::scales::{self, Scale};
use reprise_numerics::gplvm::{Hyper, Jitter, LatentModel, LikelihoodConfig, MeanPredictor, Predictor, RigMap};
use reprise_stagekit::{StageError, StageResult};

pub use reprise_numerics::gplvm::LatentModel as Model;
pub use scaling::Scaling;

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
    Scaling::new(&pca.label, controls, scales, scales_path)?.rig_map(pca)
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
    let predictor = if g.is_sparse() {
        let mean = MeanPredictor::from_parts(g.inducing.clone(), g.kinv_y.clone(), g.q, g.d, hyper).map_err(bad)?;
        Predictor::from_sparse_mean(mean, &g.x).map_err(bad)?
    } else {
        let mean = MeanPredictor::from_parts(g.x.clone(), g.kinv_y.clone(), g.q, g.d, hyper).map_err(bad)?;
        Predictor::from_mean(mean, &config).map_err(bad)?
    };
    let map = rig_map(pca, controls, scales, paths[2])?;
    LatentModel::new(g.label.clone(), predictor, g.x.clone(), g.offset.clone(), map).map_err(bad)
}

/// Refuses model artifacts that do not belong together: `gplvm_models` must have been fit
/// on these `pca_models` and `scales`, and `pca_models` computed from these `scales` (by
/// the input hashes each records in its provenance; an artifact without provenance is not
/// checked). A mix from two runs would otherwise assemble models whose latent space and
/// rig map disagree, silently. The error names both files and what to rerun.
pub fn check_chain(gplvm_models: &Path, pca_models: &Path, scales_path: &Path) -> StageResult<()> {
    let given = reprise_stagekit::provenance("models", "0", &())
        .with_input("pca_models", pca_models)?
        .with_input("scales", scales_path)?;
    reprise_artifact::provenance::check_made_from(gplvm_models, &given)?;
    reprise_artifact::provenance::check_made_from(pca_models, &given)?;
    Ok(())
}

/// [`check_chain`], plus what the synthesis library adds: `latents` written by the same
/// gplvm run as `gplvm_models`, and `bridges` searched on these models, PCA and scales. A
/// mix (e.g. bridges of an earlier fit) would route transitions through latent points of
/// another model. The error names both files.
pub fn check_library(
    gplvm_models: &Path,
    latents: &Path,
    pca_models: &Path,
    scales_path: &Path,
    bridges: &Path,
) -> StageResult<()> {
    check_chain(gplvm_models, pca_models, scales_path)?;
    reprise_artifact::provenance::check_same_run(latents, gplvm_models, &[])?;
    let given = reprise_stagekit::provenance("models", "0", &())
        .with_input("gplvm_models", gplvm_models)?
        .with_input("pca_models", pca_models)?
        .with_input("scales", scales_path)?;
    reprise_artifact::provenance::check_made_from(bridges, &given)?;
    Ok(())
}

/// Loads every label's model from the `gplvm_models`, `pca_models` and `scales` artifacts,
/// after checking that they belong together ([`check_chain`]).
pub fn load(gplvm_models: &Path, pca_models: &Path, scales_path: &Path) -> StageResult<Models> {
    check_chain(gplvm_models, pca_models, scales_path)?;
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

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    use reprise_artifact::{table, Columns, Kind};

    /// A one-column artifact made by `stage` from `inputs` (role, file).
    fn artifact(dir: &Path, name: &str, stage: &str, value: f64, inputs: &[(&str, &Path)]) -> PathBuf {
        let path = dir.join(name);
        let mut prov = reprise_stagekit::provenance(stage, "0", &());
        for (role, p) in inputs {
            prov = prov.with_input(role, p).unwrap();
        }
        table::write(&path, Kind { name: "t", version: 1 }, Columns::new().f64("x", vec![value]), &prov, &[]).unwrap();
        path
    }

    /// Catalogue: GPLVM models fit on another run's PCA or scales (e.g. after the scales
    /// were recomputed and only some stages rerun by hand) are refused naming both files.
    #[test]
    fn models_of_another_run_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let scales = artifact(d, "scales.parquet", "scale", 1.0, &[]);
        let pca = artifact(d, "pca.parquet", "pca", 2.0, &[("scales", &scales)]);
        let gplvm = artifact(d, "gplvm.parquet", "gplvm", 3.0, &[("pca_models", &pca), ("scales", &scales)]);
        super::check_chain(&gplvm, &pca, &scales).unwrap();
        let other = artifact(d, "scales2.parquet", "scale", 9.0, &[]);
        let e = super::check_chain(&gplvm, &pca, &other).unwrap_err();
        assert_eq!(e.code(), reprise_stagekit::exit::INPUT);
        let msg = e.to_string();
        assert!(
            msg.contains("gplvm.parquet: was made by `gplvm` from scales") && msg.contains("scales2.parquet"),
            "{msg}"
        );
        let pca2 = artifact(d, "pca2.parquet", "pca", 5.0, &[("scales", &scales)]);
        let msg = super::check_chain(&gplvm, &pca2, &scales).unwrap_err().to_string();
        assert!(msg.contains("from pca_models") && msg.contains("pca2.parquet"), "{msg}");
    }

    /// Catalogue: bridges searched on an earlier fit, or latents of another gplvm run,
    /// are refused beside these models.
    #[test]
    fn a_library_of_two_runs_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let scales = artifact(d, "scales.parquet", "scale", 1.0, &[]);
        let pca = artifact(d, "pca.parquet", "pca", 2.0, &[("scales", &scales)]);
        let inputs: [(&str, &Path); 2] = [("pca_models", &pca), ("scales", &scales)];
        let gplvm = artifact(d, "gplvm.parquet", "gplvm", 3.0, &inputs);
        let latents = artifact(d, "latents.parquet", "gplvm", 4.0, &inputs);
        let old = artifact(d, "old_gplvm.parquet", "gplvm", 7.0, &inputs);
        let bridges = artifact(d, "bridges.parquet", "bridges", 5.0, &[("gplvm_models", &gplvm)]);
        let stale = artifact(d, "stale.parquet", "bridges", 6.0, &[("gplvm_models", &old)]);
        super::check_library(&gplvm, &latents, &pca, &scales, &bridges).unwrap();
        let msg = super::check_library(&gplvm, &latents, &pca, &scales, &stale).unwrap_err().to_string();
        assert!(
            msg.contains("stale.parquet: was made by `bridges` from gplvm_models") && msg.contains("old_gplvm.parquet"),
            "{msg}"
        );
        let other_latents = artifact(d, "l2.parquet", "gplvm", 4.0, &[("pca_models", &pca)]);
        let msg = super::check_library(&gplvm, &other_latents, &pca, &scales, &bridges).unwrap_err().to_string();
        assert!(msg.contains("l2.parquet and ") && msg.contains("written by different runs"), "{msg}");
    }
}
