//! Mesh primitives and skins of the default scene, read once into flat arrays for the rig.

use glam::{DAffine3, DMat4, DVec3};

use crate::controls::{default_weights, Layout};
use crate::error::GltfError;
use crate::load::Loaded;
use crate::scene::SceneGraph;

/// Linear-blend-skinning influences of one primitive, in compressed-row form.
#[derive(Debug, Clone)]
pub(crate) struct Influences {
    /// Vertex `v`'s influences are `starts[v]..starts[v + 1]`.
    pub starts: Vec<u32>,
    /// Index into the rig's joint-matrix array (skin offset + joint slot).
    pub joint: Vec<u32>,
    /// Weights, normalised to sum to 1 per vertex.
    pub weight: Vec<f64>,
}

/// One mesh primitive instanced by one node of the default scene.
#[derive(Debug, Clone)]
pub(crate) struct Primitive {
    pub node: usize,
    pub first_vertex: usize,
    /// Bind-space / mesh-space positions (POSITION).
    pub positions: Vec<DVec3>,
    /// Per morph target, POSITION deltas (empty when the target moves no position).
    pub targets: Vec<Vec<DVec3>>,
    /// Morph weights when no control overrides them (node's, else mesh's, else 0).
    pub default_weights: Vec<f64>,
    /// First morph control of the node, when its weights are controls.
    pub morph_controls: Option<usize>,
    /// `Some` for a skinned node: positions are skinned and the node's own transform ignored.
    pub skin: Option<Influences>,
}

/// A skin: joint nodes and inverse bind matrices, joint matrices stored from `offset` on.
#[derive(Debug, Clone)]
pub(crate) struct Skin {
    pub joints: Vec<usize>,
    pub inverse_bind: Vec<DAffine3>,
    pub offset: usize,
}

pub(crate) fn read_skins(l: &Loaded) -> Result<Vec<Skin>, GltfError> {
    let mut offset = 0;
    let mut skins = Vec::new();
    for skin in l.doc.skins() {
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        let inverse_bind: Vec<DAffine3> = match skin.reader(|b| l.buffer(b)).read_inverse_bind_matrices() {
            Some(it) => {
                it.map(|m| DAffine3::from_mat4(DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from))))).collect()
            }
            None if skin.inverse_bind_matrices().is_some() => {
                return Err(accessor_err(l, format!("skin {} inverseBindMatrices", skin.index()), "unreadable".into()))
            }
            None => vec![DAffine3::IDENTITY; joints.len()],
        };
        if inverse_bind.len() < joints.len() {
            return Err(accessor_err(
                l,
                format!("skin {} inverseBindMatrices", skin.index()),
                format!("{} matrices for {} joints", inverse_bind.len(), joints.len()),
            ));
        }
        skins.push(Skin { joints, inverse_bind, offset });
        offset += skins.last().map_or(0, |s| s.joints.len());
    }
    Ok(skins)
}

fn accessor_err(l: &Loaded, what: String, reason: String) -> GltfError {
    GltfError::Accessor { path: l.path.clone(), what, reason }
}

/// Every primitive of every mesh node in the default scene, in scene order, with its
/// triangles (vertex indices offset into the concatenated vertex array).
pub(crate) fn read_primitives(
    l: &Loaded,
    graph: &SceneGraph,
    layout: &Layout,
    skins: &[Skin],
) -> Result<(Vec<Primitive>, Vec<[u32; 3]>), GltfError> {
    let nodes: Vec<gltf::Node<'_>> = l.doc.nodes().collect();
    let mut prims = Vec::new();
    let mut triangles = Vec::new();
    let mut first_vertex = 0usize;
    for &ni in &graph.scene_order {
        let node = &nodes[ni];
        let Some(mesh) = node.mesh() else { continue };
        let node_name = &graph.nodes[ni].name;
        let morph_controls = layout.by_node[ni].and_then(|i| layout.per_node[i].morph).map(|(base, _)| base);
        for p in mesh.primitives() {
            let what = |attr: &str| format!("node '{node_name}' mesh {} primitive {} {attr}", mesh.index(), p.index());
            let reader = p.reader(|b| l.buffer(b));
            let positions: Vec<DVec3> = reader
                .read_positions()
                .ok_or_else(|| accessor_err(l, what("POSITION"), "missing or not float VEC3".into()))?
                .map(|v| DVec3::from_array(v.map(f64::from)))
                .collect();
            let n = positions.len();
            let mut targets = Vec::new();
            for (k, (pos, _, _)) in reader.read_morph_targets().enumerate() {
                let deltas: Vec<DVec3> =
                    pos.map(|it| it.map(|v| DVec3::from_array(v.map(f64::from))).collect()).unwrap_or_default();
                if !deltas.is_empty() && deltas.len() != n {
                    return Err(accessor_err(
                        l,
                        what(&format!("morph target {k} POSITION")),
                        format!("{} deltas for {n} vertices", deltas.len()),
                    ));
                }
                targets.push(deltas);
            }
            let count = targets.len();
            let skin = match node.skin() {
                Some(s) => Some(read_influences(l, &reader, &skins[s.index()], n, &what)?),
                None => None,
            };
            let indices: Vec<u32> = match reader.read_indices() {
                Some(it) => it.into_u32().collect(),
                None => (0..n as u32).collect(),
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
                return Err(accessor_err(l, what("indices"), format!("index {bad} out of range for {n} vertices")));
            }
            let off = first_vertex as u32;
            let tri = |a: u32, b: u32, c: u32| [a + off, b + off, c + off];
            use gltf::mesh::Mode;
            match p.mode() {
                Mode::Triangles => triangles.extend(indices.chunks_exact(3).map(|t| tri(t[0], t[1], t[2]))),
                Mode::TriangleStrip => triangles.extend(indices.windows(3).enumerate().map(|(i, w)| {
                    if i % 2 == 0 {
                        tri(w[0], w[1], w[2])
                    } else {
                        tri(w[1], w[0], w[2])
                    }
                })),
                Mode::TriangleFan if indices.len() >= 3 => {
                    triangles.extend(indices[1..].windows(2).map(|w| tri(indices[0], w[0], w[1])))
                }
                _ => {} // points and lines: vertices only
            }
            prims.push(Primitive {
                node: ni,
                first_vertex,
                positions,
                targets,
                default_weights: default_weights(node, &mesh, count),
                morph_controls,
                skin,
            });
            first_vertex += n;
        }
    }
    Ok((prims, triangles))
}

/// One JOINTS_n/WEIGHTS_n pair, per vertex.
type JointWeightSet = (Vec<[u16; 4]>, Vec<[f32; 4]>);

/// JOINTS_n/WEIGHTS_n (n = 0, 1, …) → normalised influences. A vertex whose weights sum to
/// zero is bound fully to its first listed joint (as three.js does).
fn read_influences<'a, 's, F>(
    l: &Loaded,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    skin: &Skin,
    n: usize,
    what: &dyn Fn(&str) -> String,
) -> Result<Influences, GltfError>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    if skin.joints.is_empty() {
        return Err(accessor_err(l, what("skin"), "the node's skin has no joints".into()));
    }
    let mut sets: Vec<JointWeightSet> = Vec::new();
    for set in 0.. {
        let (Some(j), Some(w)) = (reader.read_joints(set), reader.read_weights(set)) else { break };
        let (j, w): (Vec<[u16; 4]>, Vec<[f32; 4]>) = (j.into_u16().collect(), w.into_f32().collect());
        if j.len() != n || w.len() != n {
            return Err(accessor_err(
                l,
                what(&format!("JOINTS_{set}/WEIGHTS_{set}")),
                format!("counts {}/{} for {n} vertices", j.len(), w.len()),
            ));
        }
        sets.push((j, w));
    }
    if sets.is_empty() {
        return Err(accessor_err(l, what("JOINTS_0/WEIGHTS_0"), "skinned node but no joints/weights".into()));
    }
    let mut inf = Influences { starts: Vec::with_capacity(n + 1), joint: Vec::new(), weight: Vec::new() };
    for v in 0..n {
        inf.starts.push(inf.joint.len() as u32);
        let start = inf.joint.len();
        for (js, ws) in &sets {
            for c in 0..4 {
                let (j, w) = (js[v][c] as usize, f64::from(ws[v][c]));
                if w > 0.0 {
                    if j >= skin.joints.len() {
                        return Err(accessor_err(
                            l,
                            what("JOINTS"),
                            format!("vertex {v} uses joint {j} of a {}-joint skin", skin.joints.len()),
                        ));
                    }
                    inf.joint.push((skin.offset + j) as u32);
                    inf.weight.push(w);
                }
            }
        }
        let total: f64 = inf.weight[start..].iter().sum();
        if total > 0.0 {
            inf.weight[start..].iter_mut().for_each(|w| *w /= total);
        } else {
            inf.joint.push((skin.offset + sets[0].0[v][0] as usize).min(skin.offset + skin.joints.len() - 1) as u32);
            inf.weight.push(1.0);
        }
    }
    inf.starts.push(inf.joint.len() as u32);
    Ok(inf)
}
