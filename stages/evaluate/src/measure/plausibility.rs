//! Plausibility: how far a played pose is from the nearest training pose, measured twice —
//! against the raw training frames, and floor-matched: against the nearer of a training
//! frame and a training frame projected through its own label's PCA, so replaying a frame
//! and reproducing its PCA projection both score 0 — in scaled control space and on the
//! mesh, and kept apart by phase.
//!
//! Units: a distance in scaled control space is divided by the median distance between
//! consecutive training frames there ([`crate::training::Training::step`]); an RMS vertex distance by the
//! median RMS vertex motion between consecutive training frames ([`crate::training::Training::mesh_step`]).
//! "3" reads "as far from any training pose as three frames of typical motion".

use std::ops::Range;

use super::nearest::Cache;
use super::Phase;

/// Where a distance is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Space {
    /// Scaled control space $z = \bar w \odot p$.
    Scaled,
    /// RMS vertex distance on the mesh (nearest among the scaled space's nearest candidates).
    Mesh,
}

/// Which training poses the distance is to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reference {
    /// The training frames.
    Raw,
    /// The training frames and their projections through their own label's PCA (the
    /// nearer of the two).
    Floor,
}

impl Space {
    /// Both spaces.
    pub const ALL: [Space; 2] = [Space::Scaled, Space::Mesh];
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Space::Scaled => "scaled",
            Space::Mesh => "mesh",
        }
    }
}

impl Reference {
    /// Both references.
    pub const ALL: [Reference; 2] = [Reference::Raw, Reference::Floor];
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Reference::Raw => "raw",
            Reference::Floor => "floor",
        }
    }
}

/// The metric name of a plausibility measure: `plausibility_<reference>_<space>`, with
/// `_<phase>` for one phase (none: reach, blend and settle together — the answer).
pub fn metric_name(reference: Reference, space: Space, phase: Option<Phase>) -> String {
    match phase {
        None => format!("plausibility_{}_{}", reference.name(), space.name()),
        Some(p) => format!("plausibility_{}_{}_{}", reference.name(), space.name(), p.name()),
    }
}

/// One answer's normalised distances, per (reference, space, phase).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plausibility {
    values: [[[Vec<f64>; 4]; 2]; 2],
}

impl Plausibility {
    /// Measures every `stride`-th frame after the request of an answer (its nearest
    /// poses in `near`), split into `phases` (as [`Phase::ranges`]; the hold is context and
    /// not measured).
    pub fn measure(near: &mut Cache<'_>, phases: &[Range<usize>; 4], stride: usize) -> Self {
        let mut out = Self::default();
        let training = near.training();
        for t in (phases[1].start..phases[3].end).step_by(stride.max(1)) {
            let Some(phase) = phases.iter().position(|r| r.contains(&t)) else { continue };
            let (raw, floor) = near.get(t);
            for (ri, n) in [raw, floor].into_iter().enumerate() {
                out.values[ri][0][phase].push(n.scaled / training.step);
                out.values[ri][1][phase].push(n.mesh / training.mesh_step);
            }
        }
        out
    }

    /// The mean distance over one phase, or over the answer after the request for `None`
    /// (NaN without frames there): one value per request.
    pub fn phase_mean(&self, reference: Reference, space: Space, phase: Option<Phase>) -> f64 {
        let v = self.values(reference, space, phase);
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    }

    /// The distances of one phase, or of the answer (reach, blend and settle) for `None`.
    pub fn values(&self, reference: Reference, space: Space, phase: Option<Phase>) -> Vec<f64> {
        let ri = Reference::ALL.iter().position(|r| *r == reference).unwrap_or(0);
        let si = Space::ALL.iter().position(|s| *s == space).unwrap_or(0);
        let v = &self.values[ri][si];
        match phase {
            Some(p) => v[Phase::ALL.iter().position(|q| *q == p).unwrap_or(0)].clone(),
            None => v[1..].concat(),
        }
    }

    /// The mean distance over the answer after the request (NaN without frames).
    pub fn mean(&self, reference: Reference, space: Space) -> f64 {
        self.phase_mean(reference, space, None)
    }
}
