//! A glTF character as a rig: control vector → world-space mesh vertices.
//!
//! Controls are the same list, in the same order, as [`crate::ingest`] produces for the file
//! (see [`crate::controls`] for their meaning). Evaluation:
//! 1. node locals: rest TRS with the controls applied (`R = R_rest · exp([v]×)`,
//!    `t = t_rest + Δt`, `s = s_rest ⊙ ratio`); globals through the parent chain;
//! 2. per primitive of the default scene (scene order, see [`SceneGraph::scene_order`]):
//!    morph targets (weights: node/mesh defaults, overridden by morph controls), then
//!    * skinned node: linear blend skinning `Σ wᵢ · G(jointᵢ) · IBMᵢ · p` with JOINTS_n /
//!      WEIGHTS_n (weights renormalised to sum 1; the node's own transform is ignored, as
//!      the glTF spec requires);
//!    * other nodes: the node's global matrix.
//!
//! Output: xyz interleaved, world space of the default scene, in the file's units (metres).

use std::path::Path;

use glam::{DAffine3, DVec3};

use crate::controls::{layout, NodeControls};
use crate::error::GltfError;
use crate::load::load;
use crate::mesh::{read_primitives, read_skins, Primitive, Skin};
use crate::rotation::exp;
use crate::scene::{NodeInfo, SceneGraph};

/// A glTF character's rig evaluator. Immutable after [`GltfRig::open`]; `Send + Sync`.
#[derive(Debug, Clone)]
pub struct GltfRig {
    names: Vec<String>,
    defaults: Vec<f64>,
    nodes: Vec<NodeInfo>,
    topo_order: Vec<usize>,
    node_controls: Vec<Option<NodeControls>>,
    skins: Vec<Skin>,
    joint_count: usize,
    prims: Vec<Primitive>,
    triangles: Vec<[u32; 3]>,
    vertex_count: usize,
}

impl GltfRig {
    /// Reads the file and precomputes everything evaluation needs. Fails when the file has
    /// neither skins nor morph targets (no control could move a vertex).
    pub fn open(path: &Path) -> Result<Self, GltfError> {
        GltfError::contain(path, || Self::read(path))
    }

    fn read(path: &Path) -> Result<Self, GltfError> {
        let l = load(path)?;
        let has_morphs = l.doc.meshes().any(|m| m.primitives().any(|p| p.morph_targets().len() > 0));
        if l.doc.skins().len() == 0 && !has_morphs {
            return Err(GltfError::NothingToMove { path: path.to_path_buf() });
        }
        let graph = SceneGraph::from_loaded(&l)?;
        let layout = layout(&l, &graph);
        let skins = read_skins(&l)?;
        let (prims, triangles) = read_primitives(&l, &graph, &layout, &skins)?;
        let vertex_count = prims.iter().map(|p| p.positions.len()).sum();
        let mut node_controls = vec![None; graph.nodes.len()];
        for nc in &layout.per_node {
            node_controls[nc.node] = Some(nc.clone());
        }
        Ok(Self {
            names: layout.infos.iter().map(|c| c.name.clone()).collect(),
            defaults: layout.defaults(),
            nodes: graph.nodes,
            topo_order: graph.topo_order,
            node_controls,
            joint_count: skins.iter().map(|s| s.joints.len()).sum(),
            skins,
            prims,
            triangles,
            vertex_count,
        })
    }

    /// Control names, in the order [`crate::ingest`] uses.
    pub fn control_names(&self) -> &[String] {
        &self.names
    }

    /// The rest pose: rotations/translations 0, scale ratios 1, morph weights their defaults.
    pub fn default_controls(&self) -> Vec<f64> {
        self.defaults.clone()
    }

    /// Number of vertices of all primitives of the default scene.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// Triangles indexing the evaluated vertices.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Evaluates the mesh for `controls` into `out` (`3 · vertex_count` numbers, xyz
    /// interleaved, world space, metres).
    ///
    /// # Panics
    /// When `controls.len()` differs from the number of controls or `out` has the wrong length.
    pub fn evaluate(&self, controls: &[f64], out: &mut [f64]) {
        assert_eq!(controls.len(), self.names.len(), "GltfRig::evaluate: wrong number of controls");
        assert_eq!(out.len(), 3 * self.vertex_count, "GltfRig::evaluate: output must hold 3 × vertex_count numbers");
        let globals = self.globals(controls);
        let mut joints = Vec::with_capacity(self.joint_count);
        for s in &self.skins {
            joints.extend(s.joints.iter().zip(&s.inverse_bind).map(|(&j, ibm)| globals[j] * *ibm));
        }
        let mut active: Vec<(usize, f64)> = Vec::new();
        for p in &self.prims {
            active.clear();
            for (k, d) in p.default_weights.iter().enumerate() {
                let w = p.morph_controls.map_or(*d, |base| controls[base + k]);
                if w != 0.0 && !p.targets[k].is_empty() {
                    active.push((k, w));
                }
            }
            let out = &mut out[3 * p.first_vertex..3 * (p.first_vertex + p.positions.len())];
            let morphed = |v: usize| active.iter().fold(p.positions[v], |acc, &(k, w)| acc + w * p.targets[k][v]);
            match &p.skin {
                Some(inf) => {
                    for (v, o) in out.chunks_exact_mut(3).enumerate() {
                        let x = morphed(v);
                        let (a, b) = (inf.starts[v] as usize, inf.starts[v + 1] as usize);
                        let mut r = DVec3::ZERO;
                        for i in a..b {
                            r += inf.weight[i] * joints[inf.joint[i] as usize].transform_point3(x);
                        }
                        o.copy_from_slice(&r.to_array());
                    }
                }
                None => {
                    let m = globals[p.node];
                    for (v, o) in out.chunks_exact_mut(3).enumerate() {
                        o.copy_from_slice(&m.transform_point3(morphed(v)).to_array());
                    }
                }
            }
        }
    }

    /// [`GltfRig::evaluate`] into a new vector.
    pub fn evaluate_to_vec(&self, controls: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; 3 * self.vertex_count];
        self.evaluate(controls, &mut out);
        out
    }

    /// Global matrices of every node for `controls`.
    fn globals(&self, controls: &[f64]) -> Vec<DAffine3> {
        let mut g = vec![DAffine3::IDENTITY; self.nodes.len()];
        for &i in &self.topo_order {
            let n = &self.nodes[i];
            let (mut t, mut r, mut s) = (n.translation, n.rotation, n.scale);
            if let Some(nc) = &self.node_controls[i] {
                if let Some(b) = nc.rotation {
                    r *= exp(DVec3::from_slice(&controls[b..b + 3]));
                }
                if let Some(b) = nc.translation {
                    t += DVec3::from_slice(&controls[b..b + 3]);
                }
                if let Some(b) = nc.scale {
                    for a in 0..3 {
                        s[a] = if n.scale[a] != 0.0 { n.scale[a] * controls[b + a] } else { controls[b + a] };
                    }
                }
            }
            let local = DAffine3::from_scale_rotation_translation(s, r, t);
            g[i] = match n.parent {
                Some(p) => g[p] * local,
                None => local,
            };
        }
        g
    }
}
