//! The forward-kinematics rig: control vectors (the same controls ingest writes) to the
//! world positions of every joint and end site.
//!
//! Transform convention (see [`crate::skeleton`]): `world_j = world_parent · T_j · R_j`,
//! where `T_j` translates by the joint's `.tx .ty .tz` controls if it has position
//! channels (they replace the OFFSET), else by its OFFSET; `R_j` is the rotation of the
//! joint's `.rx .ry .rz` rotation vector (identity without rotation channels). An end site
//! sits at `world_parent · OFFSET`. Positions are in file units.

use std::path::Path;

use crate::error::BvhError;
use crate::parse;
use crate::rotation;
use crate::skeleton::{Bvh, ControlKind};

#[derive(Debug, Clone)]
struct RigNode {
    parent: Option<usize>,
    offset: [f64; 3],
    /// First of three translation controls, if the joint has position channels.
    translation: Option<usize>,
    /// First of three rotation controls, if the joint has rotation channels.
    rotation: Option<usize>,
}

/// A BVH skeleton as a rig: `e(controls)` = joint and end-site positions.
#[derive(Debug, Clone)]
pub struct BvhRig {
    file: String,
    controls: Vec<String>,
    vertex_names: Vec<String>,
    nodes: Vec<RigNode>,
    bones: Vec<(u32, u32)>,
    joints: usize,
}

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

impl BvhRig {
    /// Reads a BVH file. Only the hierarchy is used, but the whole file (motion included)
    /// is parsed, so a rig never opens from a malformed file.
    pub fn open(path: &Path) -> Result<Self, BvhError> {
        Ok(Self::from_bvh(&parse::read(path)?))
    }

    /// The rig of an already parsed file.
    pub fn from_bvh(bvh: &Bvh) -> Self {
        let mut nodes: Vec<RigNode> = bvh
            .nodes
            .iter()
            .map(|n| RigNode { parent: n.parent, offset: n.offset, translation: None, rotation: None })
            .collect();
        let specs = bvh.controls();
        for (column, spec) in specs.iter().enumerate().filter(|(_, s)| s.axis == 0) {
            match spec.kind {
                ControlKind::Translation => nodes[spec.node].translation = Some(column),
                ControlKind::Rotation => nodes[spec.node].rotation = Some(column),
            }
        }
        let bones = bvh.nodes.iter().enumerate().filter_map(|(i, n)| n.parent.map(|p| (p as u32, i as u32))).collect();
        BvhRig {
            file: bvh.file.clone(),
            controls: specs.into_iter().map(|s| s.name).collect(),
            vertex_names: bvh.nodes.iter().map(|n| n.name.clone()).collect(),
            nodes,
            bones,
            joints: bvh.joint_count(),
        }
    }

    /// A one-line description, e.g. `BVH skeleton 131_01.bvh: 31 joints, 7 end sites, 96 controls`.
    pub fn describe(&self) -> String {
        format!(
            "BVH skeleton {}: {} joints, {} end sites, {} controls",
            self.file,
            self.joints,
            self.nodes.len() - self.joints,
            self.controls.len()
        )
    }

    /// Control names, in the order ingest writes them.
    pub fn control_names(&self) -> &[String] {
        &self.controls
    }

    /// The default control vector: all zeros (identity rotations; translations at the
    /// parent's origin for joints with position channels, which replace the OFFSET).
    pub fn default_controls(&self) -> Vec<f64> {
        vec![0.0; self.controls.len()]
    }

    /// Number of output points: joints plus end sites.
    pub fn vertex_count(&self) -> usize {
        self.nodes.len()
    }

    /// Names of the output points, in hierarchy order (end sites are `<parent>.end`).
    pub fn vertex_names(&self) -> &[String] {
        &self.vertex_names
    }

    /// No surface: always empty.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &[]
    }

    /// `(parent, child)` vertex index pairs, one per non-root point, for drawing.
    pub fn bones(&self) -> Vec<(u32, u32)> {
        self.bones.clone()
    }

    /// Forward kinematics: writes the world position of every joint and end site, xyz
    /// interleaved in hierarchy order, into `out` (file units).
    ///
    /// # Panics
    /// If `controls.len() != control_names().len()` or `out.len() != 3 · vertex_count()`.
    pub fn evaluate(&self, controls: &[f64], out: &mut [f64]) {
        let mut scratch = vec![IDENTITY; self.nodes.len()];
        self.evaluate_with(controls, out, &mut scratch);
    }

    /// [`evaluate`](Self::evaluate) for many poses: `poses` holds whole control vectors
    /// back to back, `out` the matching position vectors.
    ///
    /// # Panics
    /// If the lengths are not whole multiples that agree with each other.
    pub fn evaluate_batch(&self, poses: &[f64], out: &mut [f64]) {
        let (width, points) = (self.controls.len(), 3 * self.nodes.len());
        let count = poses.len().checked_div(width).unwrap_or(out.len() / points.max(1));
        assert!(
            poses.len() == count * width && out.len() == count * points,
            "BvhRig::evaluate_batch: {} control values and {} outputs are not {count} poses of {width} controls and {points} coordinates",
            poses.len(),
            out.len()
        );
        let mut scratch = vec![IDENTITY; self.nodes.len()];
        for k in 0..count {
            let pose = &poses[k * width..(k + 1) * width];
            self.evaluate_with(pose, &mut out[k * points..(k + 1) * points], &mut scratch);
        }
    }

    fn evaluate_with(&self, controls: &[f64], out: &mut [f64], world: &mut [[f64; 9]]) {
        assert_eq!(controls.len(), self.controls.len(), "BvhRig::evaluate: wrong number of controls");
        assert_eq!(out.len(), 3 * self.nodes.len(), "BvhRig::evaluate: output must hold 3 × vertex_count values");
        for (i, node) in self.nodes.iter().enumerate() {
            let t = match node.translation {
                Some(c) => [controls[c], controls[c + 1], controls[c + 2]],
                None => node.offset,
            };
            let local = match node.rotation {
                Some(c) => rotation::matrix(rotation::exp([controls[c], controls[c + 1], controls[c + 2]])),
                None => IDENTITY,
            };
            match node.parent {
                None => {
                    world[i] = local;
                    out[3 * i..3 * i + 3].copy_from_slice(&t);
                }
                Some(p) => {
                    let r = world[p];
                    for row in 0..3 {
                        let base = &r[3 * row..3 * row + 3];
                        out[3 * i + row] = out[3 * p + row] + base[0] * t[0] + base[1] * t[1] + base[2] * t[2];
                        for col in 0..3 {
                            world[i][3 * row + col] =
                                base[0] * local[col] + base[1] * local[3 + col] + base[2] * local[6 + col];
                        }
                    }
                }
            }
        }
    }
}
