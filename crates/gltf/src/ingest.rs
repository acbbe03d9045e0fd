//! glTF animations → clips of rig-control curves resampled at a fixed rate.
//!
//! Each animation is one clip (named by the animation's name, `animation<index>` when
//! unnamed, later duplicates `<name>#<index>`). Frame `k` is sampled at `t_k = k / fps`
//! seconds for `k = 0 ..= round(duration · fps)`, where `duration` is the largest key time
//! of the animation. Channels a clip does not animate hold the rest value (the control's
//! default). Control semantics: see [`crate::controls`].

use std::path::Path;

use glam::{DQuat, DVec3};
use gltf::animation::Property;

use crate::channels::{read_channels, Channel};
use crate::controls::{layout, ControlInfo, Layout, NodeControls};
use crate::error::GltfError;
use crate::load::load;
use crate::rotation::ContinuousLog;
use crate::scene::{unique_names, SceneGraph};

/// One clip: `frames × controls` values, row-major (frame 0's controls first).
#[derive(Debug, Clone, PartialEq)]
pub struct ClipCurves {
    pub name: String,
    pub frames: usize,
    /// The file's own key rate: 1 / (median positive key interval over the clip's channels),
    /// or the resampling fps when the clip has fewer than two distinct key times.
    pub source_fps: f64,
    pub values: Vec<f64>,
}

/// Every clip of a file over one control list, resampled at `fps`.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfCurves {
    pub fps: f64,
    pub controls: Vec<ControlInfo>,
    pub clips: Vec<ClipCurves>,
}

impl GltfCurves {
    /// The clip called `name`, if any.
    pub fn clip(&self, name: &str) -> Option<&ClipCurves> {
        self.clips.iter().find(|c| c.name == name)
    }

    /// Index of the control called `name`, if any.
    pub fn control_index(&self, name: &str) -> Option<usize> {
        self.controls.iter().position(|c| c.name == name)
    }

    /// Frame `frame` of `clip` (one value per control).
    pub fn frame<'a>(&self, clip: &'a ClipCurves, frame: usize) -> &'a [f64] {
        let n = self.controls.len();
        &clip.values[frame * n..(frame + 1) * n]
    }
}

/// The default bound on resampled frames ([`ingest_limited`]), all animations together:
/// the same as ingest's `--max-frames` default.
pub const MAX_FRAMES: usize = 1_000_000;

/// Reads the glTF/GLB file at `path` and resamples every animation at `fps` frames/second
/// (at most [`MAX_FRAMES`] frames in all).
pub fn ingest(path: &Path, fps: f64) -> Result<GltfCurves, GltfError> {
    ingest_limited(path, fps, MAX_FRAMES)
}

/// [`ingest`] with a bound on the frames made, all animations together. Frame counts
/// come from the file's key times, so they are checked before anything is allocated.
pub fn ingest_limited(path: &Path, fps: f64, max_frames: usize) -> Result<GltfCurves, GltfError> {
    GltfError::contain(path, || read_and_sample(path, fps, max_frames))
}

fn read_and_sample(path: &Path, fps: f64, max_frames: usize) -> Result<GltfCurves, GltfError> {
    if !(fps.is_finite() && fps > 0.0) {
        return Err(GltfError::BadFps { path: path.to_path_buf(), fps });
    }
    let l = load(path)?;
    if l.doc.animations().len() == 0 {
        return Err(GltfError::NoAnimations { path: path.to_path_buf() });
    }
    let graph = SceneGraph::from_loaded(&l)?;
    let layout = layout(&l, &graph);
    let names = unique_names(l.doc.animations().map(|a| a.name()), "animation");
    let mut read = Vec::new();
    for (anim, name) in l.doc.animations().zip(names) {
        let channels = read_channels(&l, &anim, &name)?;
        read.push((name, channels));
    }
    let duration = |c: &[Channel]| c.iter().map(|c| c.track.end_time()).fold(0.0, f64::max);
    let frames = |c: &[Channel]| (duration(c) * fps).round() + 1.0;
    let total: f64 = read.iter().map(|(_, c)| frames(c)).sum();
    let width = layout.defaults().len().max(1) as f64;
    if total.is_nan() || total > max_frames as f64 || total * width > usize::MAX as f64 / 8.0 {
        if let Some((name, c)) = read.iter().max_by(|a, b| frames(&a.1).total_cmp(&frames(&b.1))) {
            return Err(GltfError::TooLong {
                path: path.to_path_buf(),
                animation: name.clone(),
                duration: duration(c),
                fps,
                frames: frames(c),
                total,
                limit: max_frames,
            });
        }
    }
    let clips: Vec<ClipCurves> =
        read.into_iter().map(|(name, channels)| sample_clip(&graph, &layout, name, channels, fps)).collect();
    let mut controls = layout.infos.clone();
    let n = controls.len();
    for (c, info) in controls.iter_mut().enumerate() {
        let observed = clips.iter().flat_map(|clip| clip.values.iter().skip(c).step_by(n.max(1)));
        let (lo, hi) = observed.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if lo <= hi {
            (info.min, info.max) = (lo, hi);
        }
        info.animated = hi > lo;
    }
    Ok(GltfCurves { fps, controls, clips })
}

fn sample_clip(graph: &SceneGraph, layout: &Layout, name: String, channels: Vec<Channel>, fps: f64) -> ClipCurves {
    let duration = channels.iter().map(|c| c.track.end_time()).fold(0.0, f64::max);
    let frames = (duration * fps).round() as usize + 1;
    let defaults = layout.defaults();
    let n = defaults.len();
    let mut values = Vec::with_capacity(frames * n);
    let mut logs: Vec<ContinuousLog> = channels.iter().map(|_| ContinuousLog::new()).collect();
    let mut buf = vec![0.0; channels.iter().map(|c| c.track.stride()).max().unwrap_or(0)];
    for k in 0..frames {
        let t = k as f64 / fps;
        values.extend_from_slice(&defaults);
        let row = &mut values[k * n..];
        for (c, log) in channels.iter().zip(&mut logs) {
            let Some(nc) = layout.by_node[c.node].map(|i| &layout.per_node[i]) else { continue };
            let rest = &graph.nodes[c.node];
            c.track.sample(t, &mut buf);
            match (c.property, nc) {
                (Property::Rotation, &NodeControls { rotation: Some(base), .. }) => {
                    let q = DQuat::from_xyzw(buf[0], buf[1], buf[2], buf[3]).normalize();
                    let v = log.next(rest.rotation.inverse() * q);
                    row[base..base + 3].copy_from_slice(&v.to_array());
                }
                (Property::Translation, &NodeControls { translation: Some(base), .. }) => {
                    let d = DVec3::from_slice(&buf) - rest.translation;
                    row[base..base + 3].copy_from_slice(&d.to_array());
                }
                (Property::Scale, &NodeControls { scale: Some(base), .. }) => {
                    for a in 0..3 {
                        let r = rest.scale[a];
                        row[base + a] = if r != 0.0 { buf[a] / r } else { buf[a] };
                    }
                }
                (Property::MorphTargetWeights, &NodeControls { morph: Some((base, count)), .. }) => {
                    row[base..base + count].copy_from_slice(&buf[..count]);
                }
                _ => {}
            }
        }
    }
    values.iter_mut().for_each(|v| *v += 0.0); // -0.0 → 0.0, for tidy tables
    ClipCurves { name, frames, source_fps: source_fps(&channels).unwrap_or(fps), values }
}

/// 1 / median positive key interval over all channels.
fn source_fps(channels: &[Channel]) -> Option<f64> {
    let mut dts: Vec<f64> =
        channels.iter().flat_map(|c| c.track.times().windows(2).map(|w| w[1] - w[0])).filter(|&d| d > 1e-9).collect();
    if dts.is_empty() {
        return None;
    }
    dts.sort_by(f64::total_cmp);
    let m = dts.len() / 2;
    let median = if dts.len() % 2 == 1 { dts[m] } else { 0.5 * (dts[m - 1] + dts[m]) };
    Some(1.0 / median)
}
