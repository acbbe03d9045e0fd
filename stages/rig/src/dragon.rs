//! The built-in dragon-face rig behind [`Rig`](crate::Rig).

use reprise_dragonface::DragonRig;

use crate::{par_batch, Rig, RigError};

/// The dragon-face rig rebuilt from its seed.
pub struct Dragon {
    rig: DragonRig,
    names: Vec<String>,
}

impl Dragon {
    /// Rebuilds the rig, refusing a version other than this build's (the artifacts were
    /// made by other rig math and must be regenerated).
    pub fn open(seed: u64, version: &str) -> Result<Self, RigError> {
        if version != DragonRig::VERSION {
            return Err(RigError::Open {
                rig: format!("dragon-face (seed {seed})"),
                message: format!(
                    "artifacts were made with rig version `{version}`, this build has `{}`; rerun ingest",
                    DragonRig::VERSION
                ),
            });
        }
        let rig = DragonRig::new(seed);
        let names = rig.controls().iter().map(|c| c.name.clone()).collect();
        Ok(Self { rig, names })
    }

    /// The underlying rig.
    pub fn inner(&self) -> &DragonRig {
        &self.rig
    }
}

impl Rig for Dragon {
    fn describe(&self) -> String {
        format!("dragon-face (seed {})", self.rig.seed())
    }
    fn control_names(&self) -> &[String] {
        &self.names
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.rig.default_pose()
    }
    fn vertex_count(&self) -> usize {
        self.rig.vertex_count()
    }
    fn triangles(&self) -> &[[u32; 3]] {
        self.rig.triangles()
    }
    fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) -> Result<(), RigError> {
        par_batch(self, poses, out, |p, o| self.rig.evaluate(p, o))
    }
}
