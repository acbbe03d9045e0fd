//! Clips decoded from a character file (glTF, BVH) into the three ingest tables, with
//! the file named as the rig so later stages evaluate the same character.

use reprise_artifact::clips::Clip;
use reprise_artifact::controls::{Control, Controls, RigRef};
use reprise_artifact::frames::Frames;

/// One clip: name, frame count, source rate, row-major values.
pub(crate) struct ImportedClip {
    pub(crate) name: String,
    pub(crate) frames: usize,
    pub(crate) source_fps: f64,
    pub(crate) values: Vec<f64>,
}

/// Frames, controls and clips of a decoded character file.
pub(crate) fn tables(
    fps: f64,
    controls: Vec<Control>,
    clips: Vec<ImportedClip>,
    source: &str,
    rig: RigRef,
) -> (Frames, Controls, Vec<Clip>) {
    let mut frames = Frames {
        fps,
        controls: controls.iter().map(|c| c.name.clone()).collect(),
        clip: Vec::new(),
        frame: Vec::new(),
        time: Vec::new(),
        values: Vec::new(),
    };
    for clip in &clips {
        for f in 0..clip.frames {
            frames.clip.push(clip.name.clone());
            frames.frame.push(f as i64);
            frames.time.push(f as f64 / fps);
        }
        frames.values.extend_from_slice(&clip.values);
    }
    let table = Controls { controls, rig };
    let clips = clips
        .iter()
        .map(|c| Clip {
            clip: c.name.clone(),
            frames: c.frames as i64,
            fps,
            source: source.into(),
            source_fps: c.source_fps,
        })
        .collect();
    (frames, table, clips)
}

/// A BVH file: one clip named by the file stem; the skeleton is the rig.
pub(crate) fn bvh(
    path: &std::path::Path,
    fps: f64,
    max_frames: usize,
    blake3: String,
) -> Result<(Frames, Controls, Vec<Clip>), String> {
    let curves = reprise_bvh::ingest_limited(path, fps, max_frames).map_err(|e| e.to_string())?;
    let clip =
        ImportedClip { name: curves.clip, frames: curves.frames, source_fps: curves.source_fps, values: curves.values };
    let source = path.display().to_string();
    Ok(tables(fps, curves.controls, vec![clip], &source, RigRef::Bvh { path: source.clone(), blake3 }))
}

/// A glTF file: one clip per named animation; its skins and morph targets are the rig.
pub(crate) fn gltf(
    path: &std::path::Path,
    fps: f64,
    max_frames: usize,
    blake3: String,
) -> Result<(Frames, Controls, Vec<Clip>), String> {
    let curves = reprise_gltf::ingest_limited(path, fps, max_frames).map_err(|e| e.to_string())?;
    let clips = curves
        .clips
        .into_iter()
        .map(|c| ImportedClip { name: c.name, frames: c.frames, source_fps: c.source_fps, values: c.values })
        .collect();
    let source = path.display().to_string();
    Ok(tables(fps, curves.controls, clips, &source, RigRef::Gltf { path: source.clone(), blake3 }))
}
