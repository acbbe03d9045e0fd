//! The motion-matching database loaded from a pipeline's artifacts: the labeled frames in
//! the scaled control space, $z_j = w_j p_j$ ($w$ the scale weights averaged over labels;
//! a control no label's mesh depends on, $w_j = 0$, is carried with
//! $w_j = 10^{-3}\min_{w_i>0} w_i$ so every output unscales exactly), and their features.
//! Shared by the motion-match stage and the live server.

use std::collections::HashMap;
use std::path::Path;

use reprise_artifact::frames::LabeledFrames;
use reprise_matching::{crossfade_blend, Database, FeatureDb, FeatureParams, MatchError};
use reprise_numerics::pca::{Pca, PcaParams};
use reprise_stagekit::{StageError, StageResult};

/// The database: labeled frames as scaled controls, with the weights that unscale them.
pub struct Corpus {
    /// The database (scaled controls).
    pub db: Database,
    /// Its features.
    pub feats: FeatureDb,
    /// The scale weight per control.
    pub weight: Vec<f64>,
    /// Label names by the database's label ids.
    pub labels: Vec<String>,
    /// Row of (segment id, frame).
    pub rows: HashMap<(i64, i64), usize>,
}

impl Corpus {
    /// The database of `labeled` (read from `labeled_path`) in the space scaled by `weight`
    /// (from `scales_path`), with features of its top `features` principal coordinates.
    ///
    /// # Errors
    /// [`StageError::Input`] naming the file: no positive weight, a database the matching
    /// library refuses, a PCA that fails.
    pub fn build(
        labeled: &LabeledFrames,
        labeled_path: &Path,
        scales_path: &Path,
        weight: Vec<f64>,
        features: usize,
    ) -> StageResult<Self> {
        let n = labeled.frames.rows();
        let c = labeled.frames.controls.len();
        let smallest = weight.iter().copied().filter(|w| *w > 0.0).fold(f64::INFINITY, f64::min);
        if !smallest.is_finite() {
            return Err(StageError::Input(format!(
                "{}: no control has a positive scale weight (the mesh depends on none); rerun scale",
                scales_path.display()
            )));
        }
        let weight: Vec<f64> = weight.iter().map(|&w| if w > 0.0 { w } else { 1e-3 * smallest }).collect();
        let z: Vec<f64> = (0..n)
            .flat_map(|r| labeled.frames.row(r).iter().zip(&weight).map(|(p, w)| p * w).collect::<Vec<_>>())
            .collect();
        let mut labels: Vec<String> = Vec::new();
        let label_ids: Vec<u32> = labeled
            .label
            .iter()
            .map(|l| match labels.iter().position(|x| x == l) {
                Some(i) => i as u32,
                None => {
                    labels.push(l.clone());
                    (labels.len() - 1) as u32
                }
            })
            .collect();
        let mut segments = vec![0u32; n];
        for (i, &(s, e)) in labeled.segment_runs().iter().enumerate() {
            segments[s..e].iter_mut().for_each(|v| *v = i as u32);
        }
        let bad = |e: MatchError| StageError::Input(format!("{}: {e}", labeled_path.display()));
        let db = Database::new(z.clone(), c, label_ids, &segments, labeled.frames.fps).map_err(bad)?;
        let params = PcaParams { variance: 1.0, min_components: 1, max_components: features };
        let pca = Pca::fit(&z, c, &params).map_err(|e| StageError::Input(format!("feature PCA: {e}")))?;
        let q = pca.kept;
        let y: Vec<f64> = z.chunks_exact(c).flat_map(|row| pca.project(row, q)).collect();
        let feats = FeatureDb::build(&db, &y, q, &FeatureParams::default()).map_err(bad)?;
        let rows = (0..n).map(|r| ((labeled.segment_id[r], labeled.frames.frame[r]), r)).collect();
        Ok(Self { db, feats, weight, labels, rows })
    }

    /// Controls $p = z / w$ of a scaled row.
    pub fn unscale(&self, z: &[f64]) -> Vec<f64> {
        z.iter().zip(&self.weight).map(|(z, w)| z / w).collect()
    }

    /// The label's name in backquotes (the matching library knows labels by index).
    pub fn name(&self, l: u32) -> String {
        self.labels.get(l as usize).map_or_else(|| l.to_string(), |n| format!("`{n}`"))
    }

    /// One line per label whose clips are all too short for a system's full window (motion
    /// matching's continuation, the crossfade's `blend_frames`), naming the window it gets
    /// instead ([`FeatureDb::continuation_of`], [`crossfade_blend`]). A label of one-frame
    /// clips gets none: its requests fail and say why.
    pub fn short_windows(&self, blend_frames: usize) -> Vec<String> {
        let full = self.feats.continuation();
        let mut lines = Vec::new();
        for label in self.db.label_ids() {
            let mut parts = Vec::new();
            if let Some(c) = self.feats.continuation_of(label).filter(|&c| c < full) {
                parts.push(format!("searched with a {c}-frame continuation instead of {full}"));
            }
            if let Some(k) = crossfade_blend(&self.db, label, blend_frames).filter(|&k| k < blend_frames) {
                parts.push(format!("crossfaded into over {k} frames instead of {blend_frames}"));
            }
            if let (false, Some(r)) = (parts.is_empty(), self.db.longest_continuation(label)) {
                lines.push(format!(
                    "motion-match: label {} (clips of at most {} frames) is {}",
                    self.name(label),
                    r + 1,
                    parts.join(" and ")
                ));
            }
        }
        lines
    }

    /// Why a request failed, the label named.
    pub fn why(&self, e: MatchError) -> String {
        let name = |l: u32| self.name(l);
        match e {
            MatchError::NoSearchableFrames { label, needed } => format!(
                "label {} has no frame to jump to: a frame needs {needed} frame{} of continuation in its segment, \
                 and its segments are shorter",
                name(label),
                if needed == 1 { "" } else { "s" }
            ),
            MatchError::DeadEnd { frame, label } => format!(
                "playback reached the end of its segment at frame {frame} and no frame of label {} could take over",
                name(label)
            ),
            e => e.to_string(),
        }
    }
}
