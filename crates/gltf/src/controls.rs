//! The rig-control list, built deterministically from a file's animation channels.
//!
//! For every node targeted by an animation channel, in node-index order:
//! * `rotation` → `<node>.rx`, `.ry`, `.rz`: the rotation vector `v` (radians, axis·angle) with
//!   `R = R_rest · exp([v]×)`; default 0; group `joints`.
//! * `translation` → `<node>.tx`, `.ty`, `.tz`: translation minus rest translation, in the
//!   parent node's frame (unit `m`: glTF metres, times any scale on the ancestors — e.g.
//!   RobotExpressive's bones sit under a ×100 armature); default 0; group `joints`.
//! * `scale` → `<node>.sx`, `.sy`, `.sz`: scale divided by rest scale (a zero rest component
//!   makes the control the absolute scale); default 1; unit `ratio`; group `joints`.
//! * `weights` (only when the node's mesh has morph targets) → `<node>.morph.<target>`: the
//!   morph weight; target names from the mesh's `extras.targetNames` (the common exporter
//!   convention), else the target index; default the node's `weights`, else the mesh's,
//!   else 0; group `morphs`.

use crate::load::Loaded;
use crate::scene::{unique_names, SceneGraph};

/// One rig control, as the pipeline's control table lists it: group `joints` or
/// `morphs`; unit `rad`, `m`, `ratio` or `weight`; `min`/`max` observed over all clips
/// by ingest (the default when built without clips), and `animated` when they differ.
pub use reprise_artifact::controls::Control as ControlInfo;

/// Where one animated node's controls sit in the control vector.
#[derive(Debug, Clone, Default)]
pub(crate) struct NodeControls {
    pub node: usize,
    /// Index of `.rx` (then `.ry`, `.rz`).
    pub rotation: Option<usize>,
    /// Index of `.tx` (then `.ty`, `.tz`).
    pub translation: Option<usize>,
    /// Index of `.sx` (then `.sy`, `.sz`).
    pub scale: Option<usize>,
    /// Index of the first morph control and the number of morph targets.
    pub morph: Option<(usize, usize)>,
}

/// The control vector's layout.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub infos: Vec<ControlInfo>,
    pub per_node: Vec<NodeControls>,
    /// Node index → position in `per_node`.
    pub by_node: Vec<Option<usize>>,
}

impl Layout {
    pub fn defaults(&self) -> Vec<f64> {
        self.infos.iter().map(|c| c.default).collect()
    }
}

/// The number of morph targets of a mesh (the maximum over its primitives).
pub(crate) fn morph_target_count(mesh: &gltf::Mesh<'_>) -> usize {
    mesh.primitives().map(|p| p.morph_targets().len()).max().unwrap_or(0)
}

/// Default morph weights of a node instancing a mesh with `count` targets.
pub(crate) fn default_weights(node: &gltf::Node<'_>, mesh: &gltf::Mesh<'_>, count: usize) -> Vec<f64> {
    let given = node.weights().or_else(|| mesh.weights()).unwrap_or(&[]);
    (0..count).map(|k| given.get(k).map_or(0.0, |&w| f64::from(w))).collect()
}

fn target_names(mesh: &gltf::Mesh<'_>, count: usize) -> Vec<String> {
    let from_extras: Option<Vec<String>> = mesh
        .extras()
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
        .and_then(|v| v.get("targetNames")?.as_array()?.iter().map(|s| s.as_str().map(str::to_string)).collect())
        .filter(|names: &Vec<String>| names.len() == count);
    let names = from_extras.unwrap_or_default();
    unique_names((0..count).map(|k| names.get(k).map(String::as_str)), "")
}

/// Builds the control layout from every animation channel of the file.
pub(crate) fn layout(l: &Loaded, graph: &SceneGraph) -> Layout {
    let n = graph.nodes.len();
    let (mut rot, mut trans, mut scale, mut weights) = (vec![false; n], vec![false; n], vec![false; n], vec![false; n]);
    for anim in l.doc.animations() {
        for ch in anim.channels() {
            let i = ch.target().node().index();
            use gltf::animation::Property;
            match ch.target().property() {
                Property::Rotation => rot[i] = true,
                Property::Translation => trans[i] = true,
                Property::Scale => scale[i] = true,
                Property::MorphTargetWeights => weights[i] = true,
            }
        }
    }
    let mut infos = Vec::new();
    let mut per_node = Vec::new();
    let mut by_node = vec![None; n];
    let push3 = |infos: &mut Vec<ControlInfo>, node: &str, axes: [&str; 3], unit: &str, default: f64| {
        let first = infos.len();
        for a in axes {
            infos.push(ControlInfo {
                name: format!("{node}.{a}"),
                group: "joints".into(),
                unit: unit.into(),
                default,
                min: default,
                max: default,
                animated: false,
            });
        }
        first
    };
    for (i, gnode) in l.doc.nodes().enumerate() {
        let name = &graph.nodes[i].name;
        let mut nc = NodeControls { node: i, ..Default::default() };
        if rot[i] {
            nc.rotation = Some(push3(&mut infos, name, ["rx", "ry", "rz"], "rad", 0.0));
        }
        if trans[i] {
            nc.translation = Some(push3(&mut infos, name, ["tx", "ty", "tz"], "m", 0.0));
        }
        if scale[i] {
            nc.scale = Some(push3(&mut infos, name, ["sx", "sy", "sz"], "ratio", 1.0));
        }
        if let (true, Some(mesh)) = (weights[i], gnode.mesh()) {
            let count = morph_target_count(&mesh);
            if count > 0 {
                nc.morph = Some((infos.len(), count));
                let defaults = default_weights(&gnode, &mesh, count);
                for (t, d) in target_names(&mesh, count).into_iter().zip(defaults) {
                    infos.push(ControlInfo {
                        name: format!("{name}.morph.{t}"),
                        group: "morphs".into(),
                        unit: "weight".into(),
                        default: d,
                        min: d,
                        max: d,
                        animated: false,
                    });
                }
            }
        }
        if nc.rotation.is_some() || nc.translation.is_some() || nc.scale.is_some() || nc.morph.is_some() {
            by_node[i] = Some(per_node.len());
            per_node.push(nc);
        }
    }
    Layout { infos, per_node, by_node }
}
