//! The synthesis engine's library, loaded from a pipeline's artifacts: the label models
//! (GPLVM over PCA over scales, [`reprise_label_models`]), each model's training frames
//! (from `gplvm_latents`) and the bridges, shared by every stage that runs the engine
//! (`synthesize`, `transitions`).
#![warn(missing_docs)]

pub mod matching;

use reprise_artifact::{bridges, gplvm};
use reprise_stagekit::{StageError, StageResult};
use reprise_synth_engine::engine::{Library, Link, Settings, TrainingFrame};

/// What the synthesis engine's [`Library`] borrows: the label models, each model's training
/// frames (from `gplvm_latents`, in the model's point order) and the bridges.
#[derive(Debug)]
pub struct LibraryParts {
    /// The models.
    pub models: reprise_label_models::Models,
    /// Per model, its training frames.
    pub frames: Vec<Vec<TrainingFrame>>,
    /// The bridges.
    pub links: Vec<Link>,
}

impl LibraryParts {
    /// Loads models, latents and bridges, checking that every model has one latent row per
    /// training point.
    pub fn load(
        gplvm_models: &std::path::Path,
        latents: &std::path::Path,
        pca_models: &std::path::Path,
        scales: &std::path::Path,
        bridges_path: &std::path::Path,
    ) -> StageResult<Self> {
        reprise_label_models::check_library(gplvm_models, latents, pca_models, scales, bridges_path)?;
        let models = reprise_label_models::load(gplvm_models, pca_models, scales)?;
        let lat = gplvm::read_latents(latents)?;
        let frames = models
            .models
            .iter()
            .map(|m| {
                let f: Vec<TrainingFrame> = (0..lat.label.len())
                    .filter(|&r| lat.label[r] == m.label)
                    .map(|r| TrainingFrame {
                        segment: lat.segment_id[r],
                        clip: lat.clip[r].clone(),
                        frame: lat.frame[r],
                        x: lat.x[r].clone(),
                    })
                    .collect();
                if f.len() != m.frames() {
                    return Err(StageError::Input(format!(
                        "{}: label `{}` has {} latent rows but its model {} points; rerun gplvm",
                        latents.display(),
                        m.label,
                        f.len(),
                        m.frames()
                    )));
                }
                Ok(f)
            })
            .collect::<StageResult<_>>()?;
        let links = bridges::read(bridges_path)?
            .into_iter()
            .map(|b| Link { from: b.from, to: b.to, x1: b.x1, x2: b.x2, distance: b.rig_distance, landing: None })
            .collect();
        Ok(Self { models, frames, links })
    }

    /// The engine's view, its landings found and idle dynamics calibrated under `set`.
    pub fn library(&self, set: &Settings) -> Library<'_> {
        Library::new(self.models.models.iter().collect(), self.frames.clone(), self.links.clone(), set)
    }
}
