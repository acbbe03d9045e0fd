//! What the server sends.
//!
//! **A frame** is one binary WebSocket message, little-endian:
//!
//! | bytes | what |
//! |---|---|
//! | 4 | `u32` frame number (0 = the session's first) |
//! | 4 | `u32` length `J` of the JSON that follows (even; padded with a space) |
//! | `J` | JSON: per system `{system, label, phase, debug, note}` ([`FrameMeta`]) |
//! | `S·3V·2` | per system, its mesh: `3V` `i16` vertex coordinates |
//!
//! A coordinate $c$ of axis $a$ is sent as $q = \operatorname{round}\big((c - lo_a)/(hi_a - lo_a)\cdot 65535\big) - 32768$,
//! clamped, with the box `[lo, hi]` of `GET /world` ([`Quantizer`]): 1/65535 of the box
//! per step (for the dragon's face, about 3 µm).

use reprise_live::game::{Event, GameFile, GameState};
use reprise_live::systems::{LiveFrame, Outcome, SYSTEM_IDS};
use reprise_live::world::World;
use reprise_stagekit::StageResult;
use serde::Serialize;

/// The box vertex coordinates are quantized in.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Quantizer {
    /// Lower corner.
    pub lo: [f64; 3],
    /// Upper corner.
    pub hi: [f64; 3],
}

/// Labeled frames sampled to find the box.
pub const BOX_SAMPLES: usize = 256;
/// The box is the sampled meshes' bounds widened by this share of their extent on every
/// side (synthesis may leave the training poses' bounds a little).
pub const BOX_MARGIN: f64 = 0.25;

impl Quantizer {
    /// The box of the world's training meshes (a sample of [`BOX_SAMPLES`] frames), widened.
    ///
    /// # Errors
    /// The rig fails.
    pub fn of_world(world: &World) -> StageResult<Self> {
        let rows = world.labeled.frames.rows();
        let step = rows.div_ceil(BOX_SAMPLES).max(1);
        let poses: Vec<Vec<f64>> = (0..rows).step_by(step).map(|r| world.labeled.frames.row(r).to_vec()).collect();
        let meshes = reprise_stagekit::rig::meshes(&world.rig, &poses)?;
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in meshes.chunks_exact(3) {
            for a in 0..3 {
                if v[a].is_finite() {
                    lo[a] = lo[a].min(v[a]);
                    hi[a] = hi[a].max(v[a]);
                }
            }
        }
        for a in 0..3 {
            if !(lo[a].is_finite() && hi[a].is_finite()) {
                (lo[a], hi[a]) = (-1.0, 1.0);
            }
            let pad = BOX_MARGIN * (hi[a] - lo[a]).max(1e-6);
            (lo[a], hi[a]) = (lo[a] - pad, hi[a] + pad);
        }
        Ok(Self { lo, hi })
    }

    /// Appends the quantized coordinates of `mesh` (`x, y, z` per vertex) to `out`.
    pub fn push(&self, mesh: &[f64], out: &mut Vec<u8>) {
        for (i, c) in mesh.iter().enumerate() {
            let a = i % 3;
            let t = ((c - self.lo[a]) / (self.hi[a] - self.lo[a]) * 65535.0).round();
            let q = (if t.is_nan() { 32768.0 } else { t.clamp(0.0, 65535.0) } - 32768.0) as i16;
            out.extend_from_slice(&q.to_le_bytes());
        }
    }

    /// The coordinate a quantized value stands for, on axis `a`.
    pub fn value(&self, a: usize, q: i16) -> f64 {
        self.lo[a] + (f64::from(q) + 32768.0) / 65535.0 * (self.hi[a] - self.lo[a])
    }
}

/// One system's part of a frame, as the page reads it.
#[derive(Debug, Clone, Serialize)]
pub struct FrameMeta<'a> {
    /// System id.
    pub system: &'a str,
    /// Label index.
    pub label: usize,
    /// Phase.
    pub phase: &'a str,
    /// Debug record.
    pub debug: &'a reprise_live::systems::Debug,
    /// Note.
    pub note: Option<&'a str>,
}

/// Encodes frame `frame` of the session's systems (`frames`, in `systems`' order).
///
/// # Errors
/// The rig fails.
pub fn encode_frame(
    world: &World,
    quant: &Quantizer,
    frame: usize,
    systems: &[String],
    frames: &[LiveFrame],
) -> StageResult<Vec<u8>> {
    let meta: Vec<FrameMeta<'_>> = systems
        .iter()
        .zip(frames)
        .map(|(s, f)| FrameMeta { system: s, label: f.label, phase: f.phase, debug: &f.debug, note: f.note.as_deref() })
        .collect();
    let mut json = serde_json::to_vec(&meta).expect("frame metadata serialises");
    if json.len() % 2 == 1 {
        json.push(b' ');
    }
    let poses: Vec<Vec<f64>> = frames.iter().map(|f| f.controls.clone()).collect();
    let meshes = reprise_stagekit::rig::meshes(&world.rig, &poses)?;
    let mut out = Vec::with_capacity(8 + json.len() + meshes.len() * 2);
    out.extend_from_slice(&(frame as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&json);
    quant.push(&meshes, &mut out);
    Ok(out)
}

/// A take's poses offered to MOVE: every this many labeled rows.
const TAKE_POSE_STEP: usize = 10;
/// At most this many poses per take.
const MAX_TAKE_POSES: usize = 64;

/// `GET /world`: what the page needs to draw, the takes of each label (for PLAY), and
/// the game's reactions (event → the labels its scripts go to), if there is a game.
pub fn world_json(world: &World, quant: &Quantizer, game: Option<&GameFile>) -> String {
    let rig = &world.rig.0;
    // Per label, its takes: (clip, every TAKE_POSE_STEP-th training frame of it).
    let mut takes: Vec<Vec<(&str, Vec<i64>)>> = vec![Vec::new(); world.labels.len()];
    let f = &world.labeled.frames;
    for (r, &l) in world.row_label.iter().enumerate() {
        let clip = f.clip[r].as_str();
        if takes[l].last().is_none_or(|t| t.0 != clip) {
            takes[l].push((clip, Vec::new()));
        }
        let poses = &mut takes[l].last_mut().expect("pushed").1;
        if poses.is_empty() || (poses.len() < MAX_TAKE_POSES && r % TAKE_POSE_STEP == 0) {
            poses.push(f.frame[r]);
        }
    }
    let reactions = game.map(|g| {
        Event::ALL
            .iter()
            .map(|&e| {
                let labels: Vec<Vec<&str>> =
                    g.scripts(e).iter().map(|s| s.steps.iter().filter_map(|st| st.command.label()).collect()).collect();
                (e.name(), labels)
            })
            .collect::<std::collections::BTreeMap<_, _>>()
    });
    let triangles: Vec<u32> = rig.triangles().iter().flatten().copied().collect();
    let bones: Vec<u32> = rig.bones().iter().flatten().copied().collect();
    serde_json::json!({
        "fps": world.fps,
        "labels": world.labels,
        // Per label, whether a session of every system can start in it, and one without
        // Motion Graphs (whose graph may leave out every frame of a small character).
        "startable": (0..world.labels.len()).map(|l| world.start_row(l).is_some()).collect::<Vec<_>>(),
        "startable_without_graph":
            (0..world.labels.len()).map(|l| world.start_row_for(l, false).is_some()).collect::<Vec<_>>(),
        "systems": SYSTEM_IDS,
        "vertices": rig.vertex_count(),
        "triangles": triangles,
        "bones": bones,
        "box": quant,
        "rig": rig.describe(),
        "takes": takes,
        "game": reactions,
    })
    .to_string()
}

/// The reply to a command: each system's outcome, and the frame it takes effect at.
pub fn outcomes_json(frame: usize, systems: &[String], outcomes: &[Outcome]) -> String {
    let per: Vec<serde_json::Value> = systems
        .iter()
        .zip(outcomes)
        .map(|(s, o)| match o {
            Outcome::Taken => serde_json::json!({"system": s, "taken": true}),
            Outcome::Ignored(why) => serde_json::json!({"system": s, "ignored": why}),
            Outcome::Refused(why) => serde_json::json!({"system": s, "refused": why}),
        })
        .collect();
    serde_json::json!({"ok": {"frame": frame, "systems": per}}).to_string()
}

/// The game's state for the client: `{"game": …}`.
pub fn game_json(state: &GameState) -> String {
    serde_json::json!({ "game": state }).to_string()
}

/// An error message for the client.
pub fn error_json(message: &str) -> String {
    serde_json::json!({ "error": message }).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantization_round_trips_within_a_step_and_clamps() {
        let q = Quantizer { lo: [-1.0, 0.0, 10.0], hi: [1.0, 2.0, 20.0] };
        let mesh = [-1.0, 0.0, 10.0, 0.3, 1.7, 19.99, 5.0, -5.0, f64::NAN];
        let mut out = Vec::new();
        q.push(&mesh, &mut out);
        let back: Vec<f64> =
            out.chunks_exact(2).enumerate().map(|(i, b)| q.value(i % 3, i16::from_le_bytes([b[0], b[1]]))).collect();
        for a in 0..6 {
            let step = (q.hi[a % 3] - q.lo[a % 3]) / 65535.0;
            assert!((back[a] - mesh[a]).abs() <= step / 2.0 + 1e-12, "{a}: {} vs {}", back[a], mesh[a]);
        }
        assert_eq!((back[6], back[7]), (1.0, 0.0), "clamped to the box");
        assert!((back[8] - 15.0).abs() < 1e-3, "NaN goes to the middle");
    }
}
