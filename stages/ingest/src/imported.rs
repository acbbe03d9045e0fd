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

/// BVH files of one skeleton: one clip per file, named by its stem; the first file's
/// skeleton is the rig (`blake3` is that file's hash). Files whose skeletons differ, or two
/// files of one stem, are refused by name; `max_frames` bounds all clips together.
pub(crate) fn bvh(
    paths: &[std::path::PathBuf],
    fps: f64,
    max_frames: usize,
    blake3: String,
) -> Result<(Frames, Controls, Vec<Clip>), String> {
    let mut clips: Vec<ImportedClip> = Vec::with_capacity(paths.len());
    let mut controls: Vec<Control> = Vec::new();
    let mut first: Option<reprise_bvh::Bvh> = None;
    let mut budget = max_frames;
    for path in paths {
        let parsed = reprise_bvh::read(path).map_err(|e| e.to_string())?;
        let stem = path.file_stem().map_or_else(|| parsed.file.clone(), |s| s.to_string_lossy().into_owned());
        if let Some(other) = clips.iter().position(|c| c.name == stem) {
            return Err(format!(
                "{} and {}: two takes named `{stem}` (a clip is named by its file's stem); rename one",
                paths[other].display(),
                path.display()
            ));
        }
        if let Some(why) = first.as_ref().and_then(|f| f.skeleton_difference(&parsed)) {
            return Err(format!(
                "{}: its skeleton differs from {}'s: {why}; one ingest reads takes of one skeleton",
                path.display(),
                paths[0].display()
            ));
        }
        if let Some((joint, gap)) = first.as_ref().and_then(|f| f.offset_gap(&parsed)) {
            eprintln!(
                "ingest: {}: OFFSETs differ from {}'s by up to {gap:.4} (`{joint}`), within {} % of the largest: \
                 one skeleton, posed with the first take's OFFSETs",
                path.display(),
                paths[0].display(),
                reprise_bvh::OFFSET_TOLERANCE * 100.0
            );
        }
        let curves = reprise_bvh::resample_limited(&parsed, &stem, fps, budget).map_err(|e| e.to_string())?;
        budget -= curves.frames;
        if controls.is_empty() {
            controls = curves.controls;
        } else {
            for (c, new) in controls.iter_mut().zip(&curves.controls) {
                c.min = c.min.min(new.min);
                c.max = c.max.max(new.max);
                c.animated |= new.animated;
            }
        }
        clips.push(ImportedClip {
            name: curves.clip,
            frames: curves.frames,
            source_fps: curves.source_fps,
            values: curves.values,
        });
        first.get_or_insert(parsed);
    }
    let rig_path = paths.first().ok_or("no BVH file given")?.display().to_string();
    let sources: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let (frames, table, mut clip_table) =
        tables(fps, controls, clips, &sources[0], RigRef::Bvh { path: rig_path, blake3 });
    for (row, source) in clip_table.iter_mut().zip(&sources) {
        row.source.clone_from(source);
    }
    Ok((frames, table, clip_table))
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
