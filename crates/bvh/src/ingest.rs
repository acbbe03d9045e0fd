//! BVH motion to rig-control curves at a fixed frame rate.
//!
//! Controls (see [`crate::skeleton`] for the transform convention):
//! - `<joint>.rx .ry .rz` (group "joints", unit "rad", default 0): the rotation vector
//!   (axis · angle) of the joint's local rotation built from its Euler channels in their
//!   declared order, continuous across frames (see [`crate::rotation::continuous_log`]).
//! - `<joint>.tx .ty .tz` (group "joints", unit "bvh" = file units, default 0): the position
//!   channels as given; an axis without a position channel carries the OFFSET's component.
//!
//! Resampling: output frame k sits at `t_k = k / fps`, k = 0 ..= ⌊duration · fps⌋ with
//! duration = (N − 1) / source_fps (see [`Bvh::source_fps`]). Rotations are slerped between
//! the two bracketing source frames, then turned into continuous rotation vectors;
//! translations are interpolated linearly.

use std::path::Path;

use crate::error::BvhError;
use crate::parse;
use crate::rotation::{self, Quat};
use crate::skeleton::{Bvh, ControlKind, Node};

/// Description of one control (a column of [`BvhCurves::values`]): the pipeline's
/// controls-table row, with `min`/`max` observed over the resampled clip.
pub use reprise_artifact::controls::Control as ControlInfo;

/// One clip of rig-control curves.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhCurves {
    /// Output frame rate.
    pub fps: f64,
    /// Clip name: the file stem.
    pub clip: String,
    /// The file's frame rate (see [`Bvh::source_fps`]).
    pub source_fps: f64,
    /// Number of output frames.
    pub frames: usize,
    pub controls: Vec<ControlInfo>,
    /// Row-major `frames × controls.len()`.
    pub values: Vec<f64>,
}

impl BvhCurves {
    /// The control values of one output frame.
    pub fn frame(&self, frame: usize) -> &[f64] {
        let n = self.controls.len();
        &self.values[frame * n..(frame + 1) * n]
    }
}

/// The default bound on resampled frames ([`resample_limited`]): the same as ingest's
/// `--max-frames` default.
pub const MAX_FRAMES: usize = 1_000_000;

/// Reads a BVH file and resamples it to `fps`; the clip is named by the file stem.
pub fn ingest(path: &Path, fps: f64) -> Result<BvhCurves, BvhError> {
    ingest_limited(path, fps, MAX_FRAMES)
}

/// [`ingest`], refusing a clip that would resample to more than `max_frames` frames.
pub fn ingest_limited(path: &Path, fps: f64, max_frames: usize) -> Result<BvhCurves, BvhError> {
    let bvh = parse::read(path)?;
    let clip = path.file_stem().map_or_else(|| bvh.file.clone(), |s| s.to_string_lossy().into_owned());
    resample_limited(&bvh, &clip, fps, max_frames)
}

/// The local rotation of `node` in one source frame.
fn frame_rotation(node: &Node, frame: &[f64]) -> Quat {
    let values = &frame[node.first_column..node.first_column + node.channels.len()];
    rotation::euler(node.channels.iter().zip(values).filter(|(c, _)| c.is_rotation()).map(|(c, &v)| (c.axis(), v)))
}

/// The local translation of `node` in one source frame: its position channels, with the
/// OFFSET's component on axes that have none.
fn frame_translation(node: &Node, frame: &[f64]) -> [f64; 3] {
    let mut t = node.offset;
    for (i, channel) in node.channels.iter().enumerate() {
        if !channel.is_rotation() {
            t[channel.axis()] = frame[node.first_column + i];
        }
    }
    t
}

/// Resamples parsed BVH motion to `fps` (see the module documentation), at most
/// [`MAX_FRAMES`] frames.
pub fn resample(bvh: &Bvh, clip: &str, fps: f64) -> Result<BvhCurves, BvhError> {
    resample_limited(bvh, clip, fps, MAX_FRAMES)
}

/// [`resample`] with a bound on the output frames. The count comes from the file
/// (`Frames:` × `Frame Time:`), so it is checked before anything is allocated: a typo in
/// the frame time (`1000` for `0.001`) is an error naming the line, not an exhausted
/// machine.
pub fn resample_limited(bvh: &Bvh, clip: &str, fps: f64, max_frames: usize) -> Result<BvhCurves, BvhError> {
    let error = |reason: String| BvhError::Resample { file: bvh.file.clone(), line: bvh.frames_line, reason };
    if !(fps.is_finite() && fps > 0.0) {
        return Err(error(format!("the target rate {fps} fps is not a positive number")));
    }
    if bvh.frames == 0 {
        return Err(error("the file has no frames".to_string()));
    }
    let source_fps = bvh.source_fps();
    let last = bvh.frames - 1;
    let duration = last as f64 / source_fps;
    let exact = (duration * fps + 1e-9).floor() + 1.0;
    let specs = bvh.controls();
    let width = specs.len();
    if exact.is_nan() || exact > max_frames as f64 || (exact as usize).checked_mul(width).is_none() {
        return Err(error(format!(
            "{} frames of {} s make {duration:.6e} s, {exact:.0} frames at {fps} fps: more than the limit of \
             {max_frames} (ingest --max-frames); is `Frame Time:` right?",
            bvh.frames, bvh.frame_time
        )));
    }
    let count = exact as usize;
    let mut values = vec![0.0; count * width];
    // Controls come in triples; the previous output frame's vector per triple.
    let mut prev = vec![[0.0; 3]; width / 3];
    for k in 0..count {
        let row = &mut values[k * width..(k + 1) * width];
        // Position of t_k in source frames, snapped to a frame when within 1e-9 of it.
        let s = k as f64 * source_fps / fps;
        let nearest = s.round();
        let s = if (s - nearest).abs() < 1e-9 { nearest } else { s };
        let i = (s.floor() as usize).min(last);
        let frac = if i == last { 0.0 } else { s - i as f64 };
        let (a, b) = (bvh.frame(i), bvh.frame((i + 1).min(last)));
        let mut column = 0;
        while column < width {
            let spec = &specs[column];
            let node = &bvh.nodes[spec.node];
            match spec.kind {
                ControlKind::Translation => {
                    let (ta, tb) = (frame_translation(node, a), frame_translation(node, b));
                    for axis in 0..3 {
                        row[column + axis] = ta[axis] + frac * (tb[axis] - ta[axis]);
                    }
                }
                ControlKind::Rotation => {
                    let q = rotation::slerp(frame_rotation(node, a), frame_rotation(node, b), frac);
                    // Continuity with this joint's vector in the previous output frame
                    // (zero, the default, before frame 0).
                    let v = rotation::continuous_log(q, prev[column / 3]);
                    prev[column / 3] = v;
                    row[column..column + 3].copy_from_slice(&v);
                }
            }
            column += 3;
        }
    }

    let controls = specs
        .iter()
        .enumerate()
        .map(|(j, spec)| {
            let column = values.iter().skip(j).step_by(width);
            let min = column.clone().copied().fold(f64::INFINITY, f64::min);
            let max = column.copied().fold(f64::NEG_INFINITY, f64::max);
            let unit = match spec.kind {
                ControlKind::Translation => "bvh",
                ControlKind::Rotation => "rad",
            };
            ControlInfo {
                name: spec.name.clone(),
                group: "joints".into(),
                unit: unit.into(),
                default: 0.0,
                min,
                max,
                animated: max > min,
            }
        })
        .collect();
    Ok(BvhCurves { fps, clip: clip.to_string(), source_fps, frames: count, controls, values })
}
