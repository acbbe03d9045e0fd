//! The node hierarchy: unique node names, rest transforms, and traversal orders.
//!
//! Names: a node's `name`, or `node<index>` when it has none; when several nodes share a
//! name, the lowest-indexed keeps it and every later one becomes `<name>#<index>`.
//! Rest transform: the node's TRS from the file (a `matrix` is decomposed), in the file's
//! units (glTF: metres), rotation a unit quaternion.

use std::collections::HashMap;
use std::path::Path;

use glam::{DAffine3, DQuat, DVec3};

use crate::error::GltfError;
use crate::load::{load, Loaded};

/// One node as found in the file.
#[derive(Debug, Clone)]
pub struct NodeInfo {
    /// Unique name (see the module docs).
    pub name: String,
    pub parent: Option<usize>,
    pub children: Vec<usize>,
    /// Rest translation (metres).
    pub translation: DVec3,
    /// Rest rotation, unit quaternion.
    pub rotation: DQuat,
    /// Rest scale (ratio).
    pub scale: DVec3,
    pub mesh: Option<usize>,
    pub skin: Option<usize>,
}

impl NodeInfo {
    /// The rest local matrix `T · R · S`.
    pub fn rest_local(&self) -> DAffine3 {
        DAffine3::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// All nodes of the file plus two orders over them.
#[derive(Debug, Clone)]
pub struct SceneGraph {
    pub nodes: Vec<NodeInfo>,
    /// Every node, parents before children (depth-first from the roots in index order).
    pub topo_order: Vec<usize>,
    /// The default scene (else the first scene, else every root) depth-first pre-order:
    /// scene roots in the scene's order, children in each node's `children` order. Mesh
    /// vertices of the rig are laid out in this order.
    pub scene_order: Vec<usize>,
}

impl SceneGraph {
    /// Reads the hierarchy of the glTF file at `path`.
    pub fn open(path: &Path) -> Result<Self, GltfError> {
        Self::from_loaded(&load(path)?)
    }

    pub(crate) fn from_loaded(l: &Loaded) -> Result<Self, GltfError> {
        let names = unique_names(l.doc.nodes().map(|n| n.name()), "node");
        let mut nodes: Vec<NodeInfo> = l
            .doc
            .nodes()
            .zip(names)
            .map(|(n, name)| {
                let (t, r, s) = n.transform().decomposed();
                let rotation = DQuat::from_array(r.map(f64::from));
                NodeInfo {
                    name,
                    parent: None,
                    children: n.children().map(|c| c.index()).collect(),
                    translation: DVec3::from_array(t.map(f64::from)),
                    rotation: if rotation.length_squared() > 0.0 { rotation.normalize() } else { DQuat::IDENTITY },
                    scale: DVec3::from_array(s.map(f64::from)),
                    mesh: n.mesh().map(|m| m.index()),
                    skin: n.skin().map(|s| s.index()),
                }
            })
            .collect();
        for p in 0..nodes.len() {
            for c in nodes[p].children.clone() {
                if let Some(other) = nodes[c].parent {
                    return Err(GltfError::Node {
                        path: l.path.clone(),
                        node: nodes[c].name.clone(),
                        reason: format!("has two parents, '{}' and '{}'", nodes[other].name, nodes[p].name),
                    });
                }
                nodes[c].parent = Some(p);
            }
        }
        let roots: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i].parent.is_none()).collect();
        let topo_order = preorder(&nodes, &roots);
        if topo_order.len() != nodes.len() {
            let stuck = (0..nodes.len()).find(|i| !topo_order.contains(i)).unwrap_or(0);
            return Err(GltfError::Node {
                path: l.path.clone(),
                node: nodes[stuck].name.clone(),
                reason: "is part of a cycle in the node hierarchy".into(),
            });
        }
        let scene_roots: Vec<usize> = match l.doc.default_scene().or_else(|| l.doc.scenes().next()) {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            None => roots,
        };
        let scene_order = preorder(&nodes, &scene_roots);
        Ok(Self { nodes, topo_order, scene_order })
    }

    /// Rest global matrices of every node (parent chain of rest locals).
    pub fn rest_globals(&self) -> Vec<DAffine3> {
        let mut g = vec![DAffine3::IDENTITY; self.nodes.len()];
        for &i in &self.topo_order {
            let local = self.nodes[i].rest_local();
            g[i] = match self.nodes[i].parent {
                Some(p) => g[p] * local,
                None => local,
            };
        }
        g
    }
}

fn preorder(nodes: &[NodeInfo], roots: &[usize]) -> Vec<usize> {
    let mut out = Vec::with_capacity(nodes.len());
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    let mut seen = vec![false; nodes.len()];
    while let Some(i) = stack.pop() {
        if std::mem::replace(&mut seen[i], true) {
            continue;
        }
        out.push(i);
        stack.extend(nodes[i].children.iter().rev());
    }
    out
}

/// `names[i]`, or `<fallback><i>` when absent; later duplicates become `<name>#<i>`.
pub(crate) fn unique_names<'a>(names: impl Iterator<Item = Option<&'a str>>, fallback: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = Vec::new();
    for (i, n) in names.enumerate() {
        let base = n.map_or_else(|| format!("{fallback}{i}"), str::to_string);
        let mut name = base.clone();
        if seen.contains_key(&name) {
            name = format!("{base}#{i}");
            // a node literally called "<base>#<i>" elsewhere: keep appending until unique
            while seen.contains_key(&name) {
                name.push_str(&format!("#{i}"));
            }
        }
        seen.insert(name.clone(), i);
        out.push(name);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::unique_names;

    #[test]
    fn names_are_unique_and_stable() {
        let got =
            unique_names([Some("Foot.L"), Some("Foot.L"), None, Some("node2"), Some("Foot.L")].into_iter(), "node");
        assert_eq!(got, ["Foot.L", "Foot.L#1", "node2", "node2#3", "Foot.L#4"]);
    }
}
