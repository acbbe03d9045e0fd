//! The transition player's content: which requests the page plays (the rule below), each
//! system's frames of them with a caption per frame (producing label, phase, the bridge
//! reprise went through, the nearest training frame), the synthesized scripts, and the
//! meshes of all of them encoded by [`crate::encode`]. The page (`html`) embeds it as JSON
//! plus base64 and `player.js` draws it; nothing here renders.
//!
//! **The rule.** Pairs: up to [`SHOWN_PAIRS`] ordered label pairs, ranked first by how many
//! systems arrive at none of the pair's requests (a failure is the most telling thing to
//! watch), then by the spread (max − min over the systems that arrive) of the pair's mean
//! perceived latency, taken greedily so that no label appears in two shown pairs. Requests
//! of a shown pair: for every system its median and its worst request of the pair by
//! perceived latency (one that never arrives is the worst), in request order, at most
//! [`REQUESTS_PER_PAIR`]. Every shown request is played by every system given, side by
//! side, aligned at the frame the transition is asked.

use std::collections::BTreeMap;

use rayon::prelude::*;
use reprise_artifact::bridges::Bridge;
use reprise_artifact::curves::Curves;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::transitions::Request;
use reprise_stagekit::rig::meshes;
use reprise_stagekit::StageResult;
use serde::Serialize;

use crate::encode::{self, Encoded, MeshSource};
use crate::measure::Phase;
use crate::systems::{Played, System};
use crate::training::{RigRef, Training};

/// Label pairs shown in the player.
pub const SHOWN_PAIRS: usize = 4;
/// At most this many requests per shown pair.
pub const REQUESTS_PER_PAIR: usize = 4;
/// At most this many frames of synthesized scripts (whole scripts, in file order).
pub const SCRIPT_FRAMES: usize = 3000;
/// The encoding's error target, as a share of the training data's median RMS vertex motion
/// between consecutive frames (one twentieth of a frame's motion).
pub const ERROR_SHARE: f64 = 0.05;

/// One system's frames of one request (or one synthesized script).
#[derive(Debug, Clone, Serialize)]
pub struct Clip {
    /// System shown name (or the script's name).
    pub system: String,
    /// First frame in the encoded frames.
    pub offset: usize,
    /// Frames.
    pub frames: usize,
    /// The frame the transition is asked at (alignment; 0 for a script).
    pub asked: i64,
    /// Latency in frames (`None`: no answer).
    pub latency: Option<i64>,
    /// Why there is no answer, or other notes.
    pub note: String,
    /// Producing label per frame (index into [`Player::labels`]).
    pub model: Vec<u16>,
    /// Phase per frame (index into [`PHASES`]).
    pub phase: Vec<u8>,
    /// The bridges gone through: (first frame, last frame, caption).
    pub bridges: Vec<(usize, usize, String)>,
    /// Script command per frame (scripts only).
    pub command: Vec<i64>,
    /// Latent point per frame, 3 decimals (empty where the curves carry none).
    pub latent: Vec<Vec<f64>>,
    /// Nearest training frame per frame: (labeled-frames row, RMS vertex distance in
    /// mesh units, 4 decimals).
    pub nearest: Vec<Nearest>,
}

/// A frame's nearest training frame: (labeled-frames row, RMS vertex distance, mesh units).
pub type Nearest = (usize, f64);

/// One request (or script) and its clips, one per system given.
#[derive(Debug, Clone, Serialize)]
pub struct Group {
    /// Title, e.g. `smile → frown · request 17 (median of reprise)`.
    pub title: String,
    /// Label pair (empty for a script).
    pub pair: (String, String),
    /// The clips.
    pub clips: Vec<Clip>,
}

/// Phase names, by the index in [`Clip::phase`].
pub const PHASES: [&str; 5] = ["hold", "reach", "blend", "settle", "script"];

/// What the player plays.
#[derive(Debug, Clone, Serialize)]
pub struct Player {
    /// The selection rule, in words.
    pub rule: String,
    /// Transitions.
    pub groups: Vec<Group>,
    /// Synthesized scripts (one clip each).
    pub scripts: Vec<Group>,
    /// Label names.
    pub labels: Vec<String>,
    /// Training rows: (clip, frame, label) per labeled-frames row.
    pub training: Vec<(String, i64, String)>,
    /// Frames per second.
    pub fps: f64,
    /// Bounding box of every encoded mesh, (x, y) low and high.
    pub bounds: [f64; 4],
    /// Triangles (flattened).
    pub triangles: Vec<u32>,
    /// Bones (flattened pairs), drawn as sticks where there are no triangles (a
    /// skeleton); with neither, the player draws every point as a dot.
    pub bones: Vec<u32>,
    /// Training median RMS vertex motion per frame (mesh units), for scale.
    pub mesh_step: f64,
    /// The encoded meshes (embedded separately as base64).
    #[serde(skip)]
    pub encoded: Option<Encoded>,
}

/// What the player is built from.
pub struct Inputs<'a> {
    /// The rig.
    pub rig: RigRef<'a>,
    /// The training reference (nearest frames).
    pub training: &'a Training,
    /// The labeled frames (names of the nearest frames).
    pub labeled: &'a LabeledFrames,
    /// The requests.
    pub requests: &'a [Request],
    /// The systems given.
    pub systems: &'a [System],
    /// Their perceived latencies, per system.
    pub arrivals: &'a Arrivals,
    /// The bridges and the models they are poses of (reprise's captions).
    pub bridges: &'a [Bridge],
    /// The GPLVM models.
    pub models: &'a reprise_label_models::Models,
    /// Synthesized scripts.
    pub curves: &'a Curves,
    /// Label order.
    pub labels: &'a [String],
    /// Blend length k (frames).
    pub window: usize,
}

/// An ordered label pair (A, B).
pub type Pair = (String, String);

/// A shown pair and its requests, each with why it was chosen.
pub type Shown<'r> = (Pair, Vec<(&'r Request, String)>);

/// Per system (in the order of the systems), its perceived latency (s) per request that
/// arrived.
pub type Arrivals = [BTreeMap<i64, f64>];

/// The requests shown, grouped by pair, with why each was chosen (see the module doc).
pub fn select<'r>(requests: &'r [Request], systems: &[System], arrivals: &Arrivals) -> Vec<Shown<'r>> {
    let mut pairs: BTreeMap<(String, String), Vec<&Request>> = BTreeMap::new();
    for r in requests {
        pairs.entry((r.from.clone(), r.to.clone())).or_default().push(r);
    }
    let index = |s: &System| systems.iter().position(|x| std::ptr::eq(x, s));
    let latency = |s: &System, r: &Request| index(s).and_then(|i| arrivals.get(i)?.get(&r.request).copied());
    // (systems answering none of the pair, spread of the others' mean latencies).
    let rank = |reqs: &[&Request]| {
        let means: Vec<f64> = systems
            .iter()
            .filter_map(|s| {
                let l: Vec<f64> = reqs.iter().filter_map(|r| latency(s, r)).collect();
                (!l.is_empty()).then(|| l.iter().sum::<f64>() / l.len() as f64)
            })
            .collect();
        let (lo, hi) = means.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| (a.min(*m), b.max(*m)));
        (systems.len() - means.len(), if means.len() > 1 { hi - lo } else { 0.0 })
    };
    let mut ranked: Vec<((usize, f64), Pair, Vec<&Request>)> =
        pairs.into_iter().map(|(p, reqs)| (rank(&reqs), p, reqs)).collect();
    ranked.sort_by(|a, b| b.0 .0.cmp(&a.0 .0).then(b.0 .1.total_cmp(&a.0 .1)));
    let mut used: Vec<&str> = Vec::new();
    let mut shown = Vec::new();
    for (_, pair, reqs) in &ranked {
        if shown.len() < SHOWN_PAIRS && !used.contains(&pair.0.as_str()) && !used.contains(&pair.1.as_str()) {
            used.extend([pair.0.as_str(), pair.1.as_str()]);
            shown.push((pair.clone(), reqs.clone()));
        }
    }
    shown
        .into_iter()
        .map(|(pair, reqs)| {
            let mut chosen: BTreeMap<i64, (&Request, Vec<String>)> = BTreeMap::new();
            for s in systems {
                // Never arriving sorts last (the worst).
                let mut by: Vec<(f64, &Request)> =
                    reqs.iter().map(|r| (latency(s, r).unwrap_or(f64::INFINITY), *r)).collect();
                by.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.request.cmp(&b.1.request)));
                for (why, (_, r)) in [("median", by[(by.len() - 1) / 2]), ("worst", by[by.len() - 1])] {
                    chosen.entry(r.request).or_insert((r, vec![])).1.push(format!("{why} of {}", s.shown));
                }
            }
            let shown = chosen.into_values().take(REQUESTS_PER_PAIR).map(|(r, why)| (r, why.join(", "))).collect();
            (pair, shown)
        })
        .collect()
}

/// Builds the player: the selected requests of every system, the scripts, their captions
/// and the encoded meshes.
pub fn build(inp: &Inputs<'_>) -> StageResult<Player> {
    let label_index = |l: &str| inp.labels.iter().position(|x| x == l).map_or(u16::MAX, |i| i as u16);
    let mut poses: Vec<Vec<f64>> = Vec::new();
    let mut groups = Vec::new();
    for (pair, reqs) in select(inp.requests, inp.systems, inp.arrivals) {
        for (r, why) in reqs {
            let mut clips = Vec::new();
            for s in inp.systems {
                let answer = s.answer(r);
                let played = s.played.get(&r.request);
                let (asked, latency) = answer.map_or((0, None), |a| (a.asked, a.latency));
                let note = answer.map(|a| a.error.clone()).filter(|e| !e.is_empty()).unwrap_or_default();
                let Some(p) = played else {
                    clips.push(empty_clip(&s.shown, poses.len(), asked, latency, note_or(note, "no frames played")));
                    continue;
                };
                let len = p.controls.len();
                let ranges = Phase::ranges(
                    len,
                    asked.max(0) as usize,
                    latency.unwrap_or(len as i64).max(0) as usize,
                    inp.window,
                );
                let phase = (0..len).map(|t| ranges.iter().position(|g| g.contains(&t)).unwrap_or(1) as u8).collect();
                let bridges = if s.id == "reprise" { bridges_gone_through(inp, p) } else { vec![] };
                clips.push(Clip {
                    system: s.shown.clone(),
                    offset: poses.len(),
                    frames: len,
                    asked,
                    latency,
                    note,
                    model: p.model.iter().map(|m| label_index(m)).collect(),
                    phase,
                    bridges,
                    command: vec![],
                    latent: if p.x.iter().all(Vec::is_empty) { vec![] } else { p.x.iter().map(|x| round(x)).collect() },
                    nearest: vec![],
                });
                poses.extend(p.controls.iter().cloned());
            }
            groups.push(Group {
                title: format!("{} → {} · request {} ({why})", pair.0, pair.1, r.request),
                pair: pair.clone(),
                clips,
            });
        }
    }
    let scripts = scripts(inp.curves, &label_index, &mut poses);
    let source = |idx: &[usize]| meshes(inp.rig, &idx.iter().map(|&i| poses[i].clone()).collect::<Vec<_>>());
    let (nearest, bounds) = nearest_frames(inp.training, &poses, &source)?;
    let encoded = encode::encode(poses.len(), inp.training.dim, &source, ERROR_SHARE * inp.training.mesh_step)?;
    let mut player = Player {
        rule: RULE.into(),
        groups,
        scripts,
        labels: inp.labels.to_vec(),
        training: (0..inp.labeled.frames.rows())
            .map(|r| (inp.labeled.frames.clip[r].clone(), inp.labeled.frames.frame[r], inp.labeled.label[r].clone()))
            .collect(),
        fps: inp.training.fps,
        bounds,
        triangles: inp.rig.0.triangles().iter().flatten().copied().collect(),
        bones: inp.rig.0.bones().into_iter().flatten().collect(),
        mesh_step: inp.training.mesh_step,
        encoded,
    };
    for c in player.groups.iter_mut().chain(player.scripts.iter_mut()).flat_map(|g| g.clips.iter_mut()) {
        c.nearest = nearest[c.offset..c.offset + c.frames].to_vec();
    }
    Ok(player)
}

const RULE: &str = "Pairs: label pairs ranked first by how many systems arrive at none of the pair's requests (arrival \
     as a viewer sees it), then by the spread (max − min over the systems that arrive) of the pair's mean perceived \
     latency, taken greedily so that no label appears in two shown pairs. Requests: for each system, its median and its \
     worst request of the pair by perceived latency (one that never arrives is the worst), in request order. Systems \
     are aligned at the frame the transition is asked.";

fn note_or(note: String, otherwise: &str) -> String {
    if note.is_empty() {
        otherwise.into()
    } else {
        note
    }
}

fn empty_clip(system: &str, offset: usize, asked: i64, latency: Option<i64>, note: String) -> Clip {
    Clip {
        system: system.into(),
        offset,
        frames: 0,
        asked,
        latency,
        note,
        model: vec![],
        phase: vec![],
        bridges: vec![],
        command: vec![],
        latent: vec![],
        nearest: vec![],
    }
}

/// The synthesized scripts (whole, in file order, up to [`SCRIPT_FRAMES`] frames), their
/// poses appended to `poses`.
fn scripts(c: &Curves, label_index: &dyn Fn(&str) -> u16, poses: &mut Vec<Vec<f64>>) -> Vec<Group> {
    let n = c.controls.len();
    let mut order: Vec<String> = Vec::new();
    for s in &c.script {
        if !order.contains(s) {
            order.push(s.clone());
        }
    }
    let mut out = Vec::new();
    let mut total = 0;
    for name in order {
        let rows: Vec<usize> = (0..c.script.len()).filter(|&r| c.script[r] == name).collect();
        if total + rows.len() > SCRIPT_FRAMES && !out.is_empty() {
            break;
        }
        total += rows.len();
        let clip = Clip {
            system: name.clone(),
            offset: poses.len(),
            frames: rows.len(),
            asked: 0,
            latency: None,
            note: String::new(),
            model: rows.iter().map(|&r| label_index(&c.model[r])).collect(),
            phase: vec![4; rows.len()],
            bridges: vec![],
            command: rows.iter().map(|&r| c.command[r]).collect(),
            latent: rows.iter().map(|&r| c.x.get(r).map_or_else(Vec::new, |x| round(x))).collect(),
            nearest: vec![],
        };
        poses.extend(rows.iter().map(|&r| c.values[r * n..(r + 1) * n].to_vec()));
        out.push(Group { title: format!("script `{name}`"), pair: (String::new(), String::new()), clips: vec![clip] });
    }
    out
}

/// Per frame the nearest training frame (see [`crate::training::Reference::nearest_row`]),
/// and the bounding box of every frame's mesh (see [`Player::bounds`]).
fn nearest_frames(
    training: &Training,
    poses: &[Vec<f64>],
    meshes: &MeshSource<'_>,
) -> StageResult<(Vec<Nearest>, [f64; 4])> {
    let dim = training.dim;
    let mut out = Vec::with_capacity(poses.len());
    let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for batch in encode::batches(poses.len()) {
        let m = meshes(&batch)?;
        out.par_extend(batch.par_iter().zip(m.par_chunks_exact(dim)).map(|(&t, m)| {
            let z = training.z(&poses[t]);
            let y = training.reduce(&z);
            training.raw.nearest_row(&z, &y, m).map_or((usize::MAX, f64::NAN), |(r, d)| (r, (d * 1e4).round() / 1e4))
        }));
        for v in m.chunks_exact(3) {
            b = [b[0].min(v[0]), b[1].min(v[1]), b[2].max(v[0]), b[3].max(v[1])];
        }
    }
    Ok((out, b))
}

/// The bridges a reprise answer went through, one per model switch L1 → L2 (frame t).
/// Where the curves carry the particle's latent points, the bridge is the one the particle
/// crossed: among the bridges L1 → L2, the one minimising
/// $\lVert x_1 - x_{t-1}\rVert + \lVert x_2 - x_t\rVert$ (the engine reaches $x_1$ in L1 and
/// starts L2's particle at $x_2$), both distances in the caption. Without latent points it
/// is inferred from poses: the bridge whose M1 pose $g_{L1}(x_1)$ is nearest the last frame
/// of L1, with that distance (scaled controls).
fn bridges_gone_through(inp: &Inputs<'_>, p: &Played) -> Vec<(usize, usize, String)> {
    let (model, controls) = (&p.model, &p.controls);
    let latent = p.x.len() == model.len() && p.x.iter().all(|x| !x.is_empty());
    let mut out = Vec::new();
    for t in 1..model.len() {
        if model[t] == model[t - 1] {
            continue;
        }
        let (l1, l2) = (&model[t - 1], &model[t]);
        let named = |b: &Bridge| {
            format!(
                "bridge {l1} → {l2} (rank {}, from point {}): x1 = ({}), x2 = ({}), rig distance {:.3}",
                b.rank,
                b.from_point,
                fmt_point(&b.x1),
                fmt_point(&b.x2),
                b.rig_distance
            )
        };
        let caption = if latent {
            crossed(inp.bridges, l1, l2, &p.x[t - 1], &p.x[t]).map(|(d1, d2, b)| {
                format!(
                    "{}; the particle left {l1} {d1:.3} from x1 and entered {l2} {d2:.3} from x2 (latent units)",
                    named(b)
                )
            })
        } else {
            let Ok(m1) = inp.models.require(l1) else { continue };
            let z = inp.training.z(&controls[t - 1]);
            inp.bridges
                .iter()
                .filter(|b| &b.from == l1 && &b.to == l2)
                .map(|b| (dist(&inp.training.z(&crate::figures::pose(m1, &b.x1)), &z), b))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|(d, b)| {
                    format!(
                        "{}; inferred — its M1 pose is {d:.3} ({:.1} median frame steps, scaled controls) from the last \
                         {l1} frame",
                        named(b),
                        d / inp.training.step
                    )
                })
        };
        let caption =
            caption.unwrap_or_else(|| format!("switch {l1} → {l2}: no bridge {l1} → {l2} in the bridges table"));
        out.push((t, (t + inp.window).min(model.len()) - 1, caption));
    }
    out
}

/// The bridge L1 → L2 a particle crossed, leaving L1 at `before` and entering L2 at
/// `after`: the one minimising $\lVert x_1 - \text{before}\rVert + \lVert x_2 -
/// \text{after}\rVert$, with both distances (latent units).
fn crossed<'b>(
    bridges: &'b [Bridge],
    l1: &str,
    l2: &str,
    before: &[f64],
    after: &[f64],
) -> Option<(f64, f64, &'b Bridge)> {
    bridges
        .iter()
        .filter(|b| b.from == l1 && b.to == l2)
        .map(|b| (dist(&b.x1, before), dist(&b.x2, after), b))
        .min_by(|a, b| (a.0 + a.1).total_cmp(&(b.0 + b.1)))
}

/// Euclidean distance (infinite between points of different dimension).
fn dist(a: &[f64], b: &[f64]) -> f64 {
    if a.len() == b.len() {
        a.iter().zip(b).map(|(u, v)| (u - v).powi(2)).sum::<f64>().sqrt()
    } else {
        f64::INFINITY
    }
}

/// A latent point to 3 decimals (what the page shows).
fn round(x: &[f64]) -> Vec<f64> {
    x.iter().map(|v| (v * 1000.0).round() / 1000.0).collect()
}

fn fmt_point(x: &[f64]) -> String {
    x.iter().map(|v| format!("{v:.2}")).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use reprise_artifact::transitions::{Answer, Answers};

    fn request(id: i64, from: &str, to: &str) -> Request {
        Request { request: id, from: from.into(), to: to.into(), segment_id: 0, clip: "c".into(), frame: 0 }
    }

    /// A system answering request `id` with `latency(id)` frames (`None`: refused).
    fn system(id: &str, reqs: &[Request], latency: impl Fn(i64) -> Option<i64>) -> System {
        let by_request = reqs
            .iter()
            .map(|r| (r.request, latency(r.request).map_or_else(|| Answer::failed("no"), |l| Answer::reached(0, l))))
            .collect();
        System::in_memory(id, Answers { system: id.into(), by_request }, BTreeMap::new())
    }

    /// Pairs: the one a system fails comes first, then the widest latency spread, and no
    /// label twice; requests: each system's median and worst, in request order.
    #[test]
    fn the_rule_picks_failures_then_spread_with_distinct_labels() {
        let mut reqs = Vec::new();
        for (k, (a, b)) in [("a", "b"), ("a", "c"), ("c", "d"), ("d", "e")].into_iter().enumerate() {
            for j in 0..3 {
                reqs.push(request(10 * k as i64 + j, a, b));
            }
        }
        let fast = system("fast", &reqs, |_| Some(1));
        // Fails a → b; slow on c → d (spread 29), a bit slow on d → e (spread 9) and a → c.
        let slow = system("slow", &reqs, |id| match id / 10 {
            0 => None,
            1 => Some(5 + id % 10),
            2 => Some(30),
            _ => Some(10 + 2 * (id % 10)),
        });
        let systems = [fast, slow];
        let arrivals: Vec<BTreeMap<i64, f64>> = systems
            .iter()
            .map(|s| reqs.iter().filter_map(|r| Some((r.request, s.answer(r)?.latency? as f64))).collect())
            .collect();
        let shown = select(&reqs, &systems, &arrivals);
        let pairs: Vec<&Pair> = shown.iter().map(|(p, _)| p).collect();
        // a → b (a failure), then c → d (spread 29); d → e shares d, a → c shares a and c.
        assert_eq!(pairs, [&("a".to_string(), "b".to_string()), &("c".to_string(), "d".to_string())]);
        let ids: Vec<i64> = shown[0].1.iter().map(|(r, _)| r.request).collect();
        // fast: all 1 frame, median 1 and worst 2 by id; slow: all refused, median 1, worst 2.
        assert_eq!(ids, [1, 2]);
        assert!(shown[0].1[1].1.contains("worst of fast") && shown[0].1[1].1.contains("worst of slow"));
    }

    /// What is missing: a system not given, a pair without requests, a pair a system
    /// answered none of.
    /// The crossed bridge is the one whose ends the particle was at, not the nearest by one end.
    #[test]
    fn the_crossed_bridge_is_found_from_both_latent_ends() {
        let bridge = |x1: [f64; 2], x2: [f64; 2], rank: i64| Bridge {
            from: "a".into(),
            to: "b".into(),
            x1: x1.to_vec(),
            x2: x2.to_vec(),
            from_point: 0,
            rig_distance: 0.0,
            mesh_distance: None,
            rank,
        };
        let bridges = vec![bridge([0.0, 0.0], [5.0, 5.0], 1), bridge([0.3, 0.0], [1.0, 1.0], 2)];
        // Nearer bridge 1's x1, but far nearer bridge 2's x2: the particle crossed bridge 2.
        let (d1, d2, b) = crossed(&bridges, "a", "b", &[0.1, 0.0], &[1.0, 1.1]).unwrap();
        assert_eq!(b.rank, 2);
        assert!((d1 - 0.2).abs() < 1e-12 && (d2 - 0.1).abs() < 1e-12, "{d1} {d2}");
        assert!(crossed(&bridges, "b", "a", &[0.0, 0.0], &[1.0, 1.0]).is_none(), "no bridge b → a");
        assert!(dist(&[0.0], &[0.0, 1.0]).is_infinite());
    }

    #[test]
    fn missing_inputs_are_said() {
        let reqs = vec![request(1, "a", "b")];
        let s = system("reprise", &reqs, |_| None);
        let notes = crate::figures::missing(&[s], &reqs, &["a".into(), "b".into()]);
        let all = notes.join("\n");
        assert!(all.contains("Motion Graphs (`motion-graphs`) was not given"), "{all}");
        assert!(all.contains("No requests for 1 of the 2 ordered label pairs") && all.contains("): b → a."), "{all}");
        assert!(all.contains("reprise answered none of the requests of 1 label pairs"), "{all}");
    }
}
