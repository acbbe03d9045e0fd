//! Reading animation channels into keyframe tracks.

use gltf::animation::util::ReadOutputs;
use gltf::animation::Property;

use crate::controls::morph_target_count;
use crate::error::GltfError;
use crate::load::Loaded;
use crate::sample::Track;

/// One channel of one animation, ready to sample.
pub(crate) struct Channel {
    pub node: usize,
    pub property: Property,
    pub track: Track,
}

/// Reads every channel of `anim`. `weights` channels on nodes without a morph-target mesh
/// are skipped (they can move nothing).
pub(crate) fn read_channels(
    l: &Loaded,
    anim: &gltf::Animation<'_>,
    anim_name: &str,
) -> Result<Vec<Channel>, GltfError> {
    let mut out = Vec::new();
    for ch in anim.channels() {
        let sampler = ch.sampler().index();
        let err = |reason: String| GltfError::Sampler {
            path: l.path.clone(),
            animation: anim_name.to_string(),
            sampler,
            reason,
        };
        let node = ch.target().node();
        let reader = ch.reader(|b| l.buffer(b));
        let times: Vec<f64> = reader
            .read_inputs()
            .ok_or_else(|| err("input (key times) accessor is unreadable".into()))?
            .map(f64::from)
            .collect();
        let outputs = reader.read_outputs().ok_or_else(|| err("output accessor is unreadable".into()))?;
        let (values, stride, quaternion): (Vec<f64>, usize, bool) = match outputs {
            ReadOutputs::Translations(it) => (it.flat_map(|v| v.map(f64::from)).collect(), 3, false),
            ReadOutputs::Scales(it) => (it.flat_map(|v| v.map(f64::from)).collect(), 3, false),
            ReadOutputs::Rotations(r) => (r.into_f32().flat_map(|v| v.map(f64::from)).collect(), 4, true),
            ReadOutputs::MorphTargetWeights(w) => {
                let count = node.mesh().map_or(0, |m| morph_target_count(&m));
                if count == 0 {
                    continue;
                }
                (w.into_f32().map(f64::from).collect(), count, false)
            }
        };
        let what = format!("{:?} of node {}", ch.target().property(), node.index());
        let track = Track::new(times, values, stride, ch.sampler().interpolation().into(), quaternion)
            .map_err(|r| err(format!("{what}: {r}")))?;
        out.push(Channel { node: node.index(), property: ch.target().property(), track });
    }
    Ok(out)
}
