//! The built-in dragon-face corpus as ingest sources: the generator's takes become
//! clips, its rig's controls become the controls table, and the rig travels as a
//! [`RigRef::DragonFace`] so later stages rebuild the same rig from its seed.

use reprise_artifact::clips::Clip;
use reprise_artifact::controls::{Control, Controls, RigRef};
use reprise_artifact::frames::Frames;
use reprise_dragon_face::{generate_corpus_scaled, DragonRig};

/// The corpus's frame rate.
pub(crate) const FPS: f64 = reprise_dragon_face::FPS;

/// Frames, controls and clips of the dragon-face corpus for `seed`, its frame budget
/// scaled by `scale`.
pub(crate) fn generate(seed: u64, scale: f64) -> (Frames, Controls, Vec<Clip>) {
    let rig = DragonRig::new(seed);
    let corpus = generate_corpus_scaled(&rig, seed, scale);
    let names: Vec<String> = rig.controls().iter().map(|c| c.name.clone()).collect();
    let n = names.len();
    let mut frames = Frames {
        fps: corpus.fps,
        controls: names,
        clip: Vec::new(),
        frame: Vec::new(),
        time: Vec::new(),
        values: Vec::new(),
    };
    let mut clips = Vec::new();
    for take in &corpus.takes {
        for f in 0..take.frame_count {
            frames.clip.push(take.name.clone());
            frames.frame.push(f as i64);
            frames.time.push(f as f64 / corpus.fps);
        }
        frames.values.extend_from_slice(&take.values[..take.frame_count * n]);
        clips.push(Clip {
            clip: take.name.clone(),
            frames: take.frame_count as i64,
            fps: corpus.fps,
            source: "dragon-face".into(),
            source_fps: corpus.fps,
        });
    }
    let controls = Controls {
        controls: rig
            .controls()
            .iter()
            .enumerate()
            .map(|(c, spec)| Control {
                name: spec.name.clone(),
                group: spec.group.clone(),
                unit: spec.unit.as_str().into(),
                default: spec.default,
                min: spec.min,
                max: spec.max,
                animated: moves(&frames, c),
            })
            .collect(),
        rig: RigRef::DragonFace { seed, version: DragonRig::VERSION.into() },
    };
    (frames, controls, clips)
}

/// Whether control `c` takes more than one value over all rows.
pub(crate) fn moves(frames: &Frames, c: usize) -> bool {
    let n = frames.controls.len();
    let first = frames.values.get(c).copied();
    (0..frames.rows()).any(|r| Some(frames.values[r * n + c]) != first)
}
