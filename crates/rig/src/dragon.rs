//! The built-in dragon-face rig behind [`Rig`](crate::Rig).

use reprise_dragon_face::DragonRig;

use crate::local::{Local, PoseEvaluator};
use crate::RigError;

/// The dragon-face rig as a [`Rig`](crate::Rig).
pub type Dragon = Local<DragonRig>;

/// Rebuilds the rig from its seed, refusing a version other than this build's (the
/// artifacts were made by other rig math and must be regenerated).
pub fn open(seed: u64, version: &str) -> Result<Dragon, RigError> {
    if version != DragonRig::VERSION {
        return Err(RigError::Open {
            rig: format!("dragon-face (seed {seed})"),
            message: format!(
                "artifacts were made with rig version `{version}`, this build has `{}`; rerun ingest",
                DragonRig::VERSION
            ),
        });
    }
    Ok(Local::new(DragonRig::new(seed)))
}

impl PoseEvaluator for DragonRig {
    fn describe(&self) -> String {
        format!("dragon-face (seed {})", self.seed())
    }
    fn control_names(&self) -> Vec<String> {
        self.controls().iter().map(|c| c.name.clone()).collect()
    }
    fn rest_pose(&self) -> Vec<f64> {
        self.default_pose()
    }
    fn vertex_count(&self) -> usize {
        DragonRig::vertex_count(self)
    }
    fn triangles(&self) -> &[[u32; 3]] {
        DragonRig::triangles(self)
    }
    fn evaluate_pose(&self, pose: &[f64], out: &mut [f64]) {
        self.evaluate(pose, out);
    }
}
