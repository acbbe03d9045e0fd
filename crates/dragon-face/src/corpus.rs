//! The hand-keyed animation corpus: eight labels, several takes each, 3,745 good frames at
//! 24 fps, plus bad takes and bad frame ranges that labeling must exclude.
//!
//! A take is built like an animator builds a shot, part by part: the neck, head, jaw,
//! mouth, lips, cheeks, brows, lids, ears, pupils, tongue and nostrils each get their own
//! key schedule (poses from the label's library, moving holds, flat-tangent eases,
//! anticipation and overshoot on big moves) with a per-take intensity and tempo, left and
//! right sides offset and different (`parts`); fine shapes and lattice points are keyed as
//! independent touch-ups (`touchups`); then layers: breathing, the head-shake and roar
//! cycles, muttering and snarls, ear and cheek secondary motion, blinks and eye saccades
//! (`layers`). Good takes are clamped to the controls' ranges.

use crate::controls::{LATTICE_N, SIDES};
use crate::parts::{parts, right_side, schedule, PartMood, ScheduleSpec};
use crate::poses::{key_pose, style};
use crate::rig::DragonRig;
use crate::{layers, touchups};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The eight expression labels of the paper.
pub const LABELS: [&str; 8] = ["happy", "grumpy", "bored", "curious", "neutral", "roar", "head_shake", "surprise"];

/// Good frames per label (after removing bad takes and bad ranges); sums to 3,745.
pub const GOOD_FRAME_BUDGET: [(&str, usize); 8] = [
    ("happy", 520),
    ("grumpy", 480),
    ("bored", 430),
    ("curious", 450),
    ("neutral", 700),
    ("roar", 380),
    ("head_shake", 330),
    ("surprise", 455),
];

/// Frames per second of the corpus.
pub const FPS: f64 = 24.0;

/// Length of the frozen off-screen range appended to one good take.
pub const BAD_RANGE_FRAMES: usize = 30;

/// What a take is, as far as training is concerned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TakeKind {
    /// Usable animation (apart from its `bad_ranges`).
    Good,
    /// Off-screen: the character is not animated (constant pose, head turned away).
    Frozen,
    /// Poses broken on purpose for one camera (one side of the face pushed past its range).
    CameraCheat,
}

/// One animated clip.
#[derive(Clone, Debug, PartialEq)]
pub struct Take {
    /// `"<label>_take<NN>"`; bad takes are named the same way (animators don't mark them).
    pub name: String,
    /// The label the animator meant.
    pub label: String,
    pub kind: TakeKind,
    pub frame_count: usize,
    /// Row-major, `frame_count × controls().len()`.
    pub values: Vec<f64>,
    /// Inclusive frame ranges that are not usable inside an otherwise good take, with a reason.
    pub bad_ranges: Vec<(usize, usize, String)>,
    /// Why the whole take must be excluded (`None` for good takes).
    pub exclusion: Option<String>,
}

impl Take {
    /// Frames usable for training: 0 for bad takes, else `frame_count` minus the bad ranges.
    pub fn good_frame_count(&self) -> usize {
        if self.kind != TakeKind::Good {
            return 0;
        }
        self.frame_count - self.bad_ranges.iter().map(|r| r.1 - r.0 + 1).sum::<usize>()
    }

    /// Control values of frame `f`.
    pub fn frame(&self, f: usize) -> &[f64] {
        let c = self.values.len() / self.frame_count;
        &self.values[f * c..(f + 1) * c]
    }
}

/// The whole corpus.
#[derive(Clone, Debug, PartialEq)]
pub struct Corpus {
    /// 24.0
    pub fps: f64,
    pub takes: Vec<Take>,
}

impl Corpus {
    /// Good frames of `label` over all takes.
    pub fn good_frames(&self, label: &str) -> usize {
        self.takes.iter().filter(|t| t.label == label).map(Take::good_frame_count).sum()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Plan {
    Good { frames: usize, bad_tail: bool },
    Frozen { frames: usize },
    Cheat { frames: usize },
}

/// Per-take variation: amplitude of the expression, tempo, staging and gaze offsets.
struct Mood {
    amp: f64,
    tempo: f64,
    yaw_bias: f64,
    gaze: (f64, f64),
}

/// Generate the corpus for `rig` (deterministic in `seed`; the default seed is 7).
pub fn generate_corpus(rig: &DragonRig, seed: u64) -> Corpus {
    generate_corpus_scaled(rig, seed, 1.0)
}

/// The corpus with every label's good-frame budget multiplied by `scale` (more and
/// longer takes; `scale = 1` is [`generate_corpus`] exactly). For benchmarks at film
/// scale: `scale ≈ 7.7` gives 20 minutes. Its bad takes are where its own
/// [`labels_toml`](crate::labels_toml) says, not where `datasets/dragon-face/labels.toml` does.
pub fn generate_corpus_scaled(rig: &DragonRig, seed: u64, scale: f64) -> Corpus {
    let mut master = ChaCha8Rng::seed_from_u64(seed ^ 0xD4A6_0F4C_E5EE_D5ED);
    let n = LABELS.len();
    let frozen_label = master.gen_range(0..n);
    let cheat_label = (frozen_label + master.gen_range(1..n)) % n;
    let tail_label = loop {
        let l = master.gen_range(0..n);
        if l != frozen_label && l != cheat_label {
            break l;
        }
    };
    let mut takes = Vec::new();
    for (li, &(label, budget)) in GOOD_FRAME_BUDGET.iter().enumerate() {
        let budget = ((budget as f64 * scale).round() as usize).max(1);
        let lo = budget.div_ceil(150).max(3);
        let hi = (budget / 90).clamp(lo, lo.max(5));
        let count = master.gen_range(lo..=hi);
        let lengths = split_budget(budget, count, &mut master);
        let tail_take = master.gen_range(0..count);
        let mut plans: Vec<Plan> = lengths
            .iter()
            .enumerate()
            .map(|(k, &frames)| Plan::Good { frames, bad_tail: li == tail_label && k == tail_take })
            .collect();
        if li == frozen_label {
            let at = master.gen_range(0..=plans.len());
            plans.insert(at, Plan::Frozen { frames: master.gen_range(48..=96) });
        }
        if li == cheat_label {
            let at = master.gen_range(0..=plans.len());
            plans.insert(at, Plan::Cheat { frames: master.gen_range(60..=100) });
        }
        for (k, plan) in plans.into_iter().enumerate() {
            let take_seed: u64 = master.gen();
            let name = format!("{label}_take{:02}", k + 1);
            takes.push(make_take(rig, label, name, plan, take_seed));
        }
    }
    Corpus { fps: FPS, takes }
}

/// Split `total` frames into `count` take lengths (random proportions 0.75..1.25).
fn split_budget(total: usize, count: usize, rng: &mut impl Rng) -> Vec<usize> {
    let w: Vec<f64> = (0..count).map(|_| rng.gen_range(0.75..1.25)).collect();
    let sum: f64 = w.iter().sum();
    let mut out: Vec<usize> = w.iter().map(|x| (total as f64 * x / sum).floor() as usize).collect();
    let used: usize = out.iter().sum();
    out[count - 1] += total - used;
    out
}

fn make_take(rig: &DragonRig, label: &str, name: String, plan: Plan, seed: u64) -> Take {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let c = rig.controls().len();
    let (kind, values, frames, bad_ranges, exclusion) = match plan {
        Plan::Good { frames, bad_tail } => {
            let mut v = animate(rig, label, frames, &mut rng);
            let mut bad = Vec::new();
            let mut total = frames;
            if bad_tail {
                let last = v[(frames - 1) * c..].to_vec();
                for _ in 0..BAD_RANGE_FRAMES {
                    v.extend_from_slice(&last);
                }
                total += BAD_RANGE_FRAMES;
                bad.push((frames, total - 1, "off-screen: character frozen after leaving the frame".to_string()));
            }
            (TakeKind::Good, v, total, bad, None)
        }
        Plan::Frozen { frames } => {
            let mut pose = key_pose(rig, label, true, &mut rng);
            let side = if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
            let mut set = |n: &str, x: f64| pose[rig.control_index(n).expect("control")] = x;
            set("head_ry", side * rng.gen_range(55.0..75.0));
            set("neck_ry", side * rng.gen_range(15.0..25.0));
            set("head_rx", rng.gen_range(-5.0..10.0));
            clamp_pose(rig, &mut pose);
            let v = pose.repeat(frames);
            let why = "off-screen: character not animated, held with the head turned away".to_string();
            (TakeKind::Frozen, v, frames, Vec::new(), Some(why))
        }
        Plan::Cheat { frames } => {
            let mut v = animate(rig, label, frames, &mut rng);
            let side = rng.gen_range(0..2);
            apply_camera_cheat(rig, &mut v, frames, side);
            let why = format!(
                "camera cheat: {} side of the face pushed past its range for one camera",
                ["left", "right"][side]
            );
            (TakeKind::CameraCheat, v, frames, Vec::new(), Some(why))
        }
    };
    Take { name, label: label.to_string(), kind, frame_count: frames, values, bad_ranges, exclusion }
}

fn clamp_pose(rig: &DragonRig, pose: &mut [f64]) {
    for (v, s) in pose.iter_mut().zip(rig.controls()) {
        *v = v.clamp(s.min, s.max);
    }
}

fn ctl(rig: &DragonRig, name: &str) -> usize {
    rig.control_index(name).unwrap_or_else(|| panic!("no control {name}"))
}

/// Controls whose big changes get anticipation and overshoot keys.
fn main_controls(rig: &DragonRig) -> Vec<usize> {
    let specs = rig.controls();
    (0..specs.len())
        .filter(|&i| specs[i].group == "head" || specs[i].group == "shapes_coarse" || specs[i].name == "jaw_open")
        .collect()
}

/// Animate one good take of `frames` frames; returns row-major values.
///
/// Every part of the face gets its own key schedule with a per-take intensity and tempo
/// (so takes of one label differ in what moves, how much and when, not by noise); the
/// right half of each sided part follows the left 0–3 frames late with a pose of its own
/// mixed in; the fine shapes and the lattice are touched up on their own clocks; then the
/// layers (breathing, label cycles, muttering, snarls, secondary motion, blinks, gaze).
fn animate(rig: &DragonRig, label: &str, frames: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let st = style(label);
    let c = rig.controls().len();
    let main = main_controls(rig);
    let mood = Mood {
        amp: rng.gen_range(0.8..1.2),
        tempo: rng.gen_range(0.85..1.2),
        yaw_bias: rng.gen_range(-1.5..1.5),
        gaze: (rng.gen_range(-8.0..8.0), rng.gen_range(-4.0..4.0)),
    };
    let mut v = vec![0.0; frames * c];
    for part in parts(rig) {
        let pm = PartMood { amp: mood.amp * rng.gen_range(0.7..1.3), tempo: mood.tempo * rng.gen_range(0.8..1.25) };
        let spec = ScheduleSpec { rig, label, style: &st, mood: pm, frames, main: &main };
        let left = schedule(&spec, rng);
        let right = (!part.right.is_empty()).then(|| {
            let lag = rng.gen_range(0.0..3.0);
            right_side(&left, lag, (0.15, 0.45), &spec, rng)
        });
        for f in 0..frames {
            let row = &mut v[f * c..(f + 1) * c];
            left.sample_into(f as f64, &part.left, row);
            if let Some(r) = &right {
                r.sample_into(f as f64, &part.right, row);
            }
        }
    }
    touchups::fine_shapes(rig, label, &st, &mut v, frames, rng);
    touchups::lattice(rig, label, &st, &mut v, frames, rng);
    layers::breathing(rig, &mut v, &st, mood.yaw_bias, rng);
    match label {
        "head_shake" => layers::head_shake(rig, &mut v, frames, rng),
        "roar" => layers::roar_tremble(rig, &mut v, frames, rng),
        _ => {}
    }
    layers::muttering(rig, label, &mut v, frames, rng);
    layers::snarls(rig, label, &mut v, frames, rng);
    layers::ear_flicks(rig, label, &mut v, frames, rng);
    layers::ear_secondary(rig, &mut v, frames, rng);
    layers::cheek_secondary(rig, &mut v, frames);
    layers::blinks(rig, &mut v, frames, &st, rng);
    layers::eyes(rig, &mut v, frames, &st, mood.gaze, rng);
    for row in v.chunks_exact_mut(c) {
        clamp_pose(rig, row);
    }
    v
}

/// Push one side of the face far outside its ranges, eased in over 6 frames.
fn apply_camera_cheat(rig: &DragonRig, v: &mut [f64], frames: usize, side: usize) {
    let c = rig.controls().len();
    let (s, sx) = SIDES[side];
    let mut targets: Vec<(usize, f64)> = vec![
        (ctl(rig, &format!("brow_up_{s}")), 1.9),
        (ctl(rig, &format!("smile_{s}")), 1.7),
        (ctl(rig, &format!("eye_wide_{s}")), 1.6),
        (ctl(rig, &format!("cheek_raise_{s}")), 1.5),
        (ctl(rig, &format!("mouth_wide_{s}")), 1.4),
        (ctl(rig, &format!("brow_{s}_inner_ty")), 3.2),
        (ctl(rig, &format!("brow_{s}_mid_ty")), 3.6),
        (ctl(rig, &format!("brow_{s}_outer_ty")), 4.0),
        (ctl(rig, &format!("eyelid_{s}_upper_rx")), -45.0),
    ];
    let i = if side == 0 { LATTICE_N - 1 } else { 0 };
    for j in 0..LATTICE_N {
        let k = LATTICE_N - 1;
        targets.push((ctl(rig, &format!("lattice_{i}{j}{k}_tx")), sx * 5.5));
        targets.push((ctl(rig, &format!("lattice_{i}{j}{k}_ty")), 4.0));
    }
    for f in 0..frames {
        let r = crate::keys::ease(f as f64 / 6.0);
        for &(i, target) in &targets {
            let x = &mut v[f * c + i];
            *x += r * (target - *x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::labels_toml;
    use std::collections::HashMap;
    use std::sync::OnceLock;

    fn rig() -> &'static DragonRig {
        static RIG: OnceLock<DragonRig> = OnceLock::new();
        RIG.get_or_init(|| DragonRig::new(7))
    }

    fn corpus() -> &'static Corpus {
        static C: OnceLock<Corpus> = OnceLock::new();
        C.get_or_init(|| generate_corpus(rig(), 7))
    }

    /// Good frames (bad takes and bad ranges removed) of `label` (all labels if None).
    fn good_rows(label: Option<&str>) -> Vec<&'static [f64]> {
        let mut rows = Vec::new();
        for t in &corpus().takes {
            if t.kind != TakeKind::Good || label.is_some_and(|l| l != t.label) {
                continue;
            }
            for f in 0..t.frame_count {
                if !t.bad_ranges.iter().any(|r| (r.0..=r.1).contains(&f)) {
                    rows.push(t.frame(f));
                }
            }
        }
        rows
    }

    fn column(rows: &[&[f64]], i: usize) -> Vec<f64> {
        rows.iter().map(|r| r[i]).collect()
    }

    fn mean_std(x: &[f64]) -> (f64, f64) {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (x.len() - 1) as f64;
        (m, v.sqrt())
    }

    fn idx(name: &str) -> usize {
        rig().control_index(name).unwrap()
    }

    #[test]
    fn deterministic_in_seed() {
        let again = generate_corpus(&DragonRig::new(7), 7);
        assert!(&again == corpus(), "same seed must give an identical corpus");
        let other = generate_corpus(rig(), 8);
        assert_ne!(&other, corpus());
        assert_ne!(other.takes[0].values, corpus().takes[0].values);
        // Same good-frame budget whatever the seed.
        for (l, n) in GOOD_FRAME_BUDGET {
            assert_eq!(other.good_frames(l), n);
        }
    }

    #[test]
    fn good_frame_budget_and_take_structure() {
        let c = corpus();
        assert_eq!(c.fps, 24.0);
        let total: usize = LABELS.iter().map(|l| c.good_frames(l)).sum();
        assert_eq!(total, 3745);
        for (l, n) in GOOD_FRAME_BUDGET {
            assert_eq!(c.good_frames(l), n, "{l}");
            assert!((100..=800).contains(&n));
            let takes: Vec<&Take> = c.takes.iter().filter(|t| t.label == l).collect();
            assert!((3..=6).contains(&takes.len()), "{l}: {} takes", takes.len());
            for (k, t) in takes.iter().enumerate() {
                assert_eq!(t.name, format!("{l}_take{:02}", k + 1));
                assert_eq!(t.values.len(), t.frame_count * rig().controls().len());
            }
        }
        let names: std::collections::HashSet<_> = c.takes.iter().map(|t| &t.name).collect();
        assert_eq!(names.len(), c.takes.len());
    }

    #[test]
    fn values_finite_and_good_takes_in_range() {
        let specs = rig().controls();
        for t in &corpus().takes {
            assert!(t.values.iter().all(|x| x.is_finite()), "{}", t.name);
            if t.kind == TakeKind::Good {
                for f in 0..t.frame_count {
                    for (x, s) in t.frame(f).iter().zip(specs) {
                        assert!(*x >= s.min && *x <= s.max, "{} frame {f}: {} = {x}", t.name, s.name);
                    }
                }
            }
        }
    }

    #[test]
    fn bad_takes_and_ranges() {
        let c = corpus();
        let specs = rig().controls();
        let frozen: Vec<&Take> = c.takes.iter().filter(|t| t.kind == TakeKind::Frozen).collect();
        assert!(!frozen.is_empty());
        for t in &frozen {
            let f0 = t.frame(0);
            assert!((1..t.frame_count).all(|f| t.frame(f) == f0), "frozen take must have zero variance");
            let yaw = f0[idx("head_ry")] + f0[idx("neck_ry")];
            assert!(yaw.abs() > 60.0, "head turned away: {yaw}");
            assert!(t.exclusion.as_deref().unwrap().starts_with("off-screen"));
        }
        let cheats: Vec<&Take> = c.takes.iter().filter(|t| t.kind == TakeKind::CameraCheat).collect();
        assert!(!cheats.is_empty());
        for t in &cheats {
            let out = (0..t.frame_count)
                .filter(|&f| t.frame(f).iter().zip(specs).any(|(x, s)| *x > s.max || *x < s.min))
                .count();
            assert!(out as f64 > 0.8 * t.frame_count as f64, "{out} of {} frames out of range", t.frame_count);
            // Only one side is cheated.
            let side = if t.exclusion.as_deref().unwrap().contains("left") { "L" } else { "R" };
            let other = if side == "L" { "R" } else { "L" };
            let last = t.frame(t.frame_count - 1);
            assert!(last[idx(&format!("brow_up_{side}"))] > 1.5);
            assert!(last[idx(&format!("brow_up_{other}"))] <= 1.0);
        }
        let ranged: Vec<&Take> = c.takes.iter().filter(|t| !t.bad_ranges.is_empty()).collect();
        assert!(!ranged.is_empty());
        for t in ranged {
            assert_eq!(t.kind, TakeKind::Good);
            let (a, b, _) = &t.bad_ranges[0];
            assert_eq!((*b, b - a + 1), (t.frame_count - 1, BAD_RANGE_FRAMES));
            assert_eq!(t.good_frame_count(), t.frame_count - BAD_RANGE_FRAMES);
            assert!((*a..=*b).all(|f| t.frame(f) == t.frame(*a)), "frozen range");
        }
        // Good takes themselves never contain a frozen stretch of 30 frames.
        for t in c.takes.iter().filter(|t| t.kind == TakeKind::Good) {
            let end = t.frame_count - t.bad_ranges.iter().map(|r| r.1 - r.0 + 1).sum::<usize>();
            for f in 0..end.saturating_sub(30) {
                assert!((f + 1..f + 30).any(|g| t.frame(g) != t.frame(f)), "{} frozen at {f}", t.name);
            }
        }
    }

    #[test]
    fn some_controls_never_move() {
        let specs = rig().controls();
        let mut still = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            if corpus().takes.iter().all(|t| (0..t.frame_count).all(|f| t.frame(f)[i] == s.default)) {
                still.push(s);
            }
        }
        assert!(still.iter().filter(|s| s.group == "tweak").count() == 24);
        // The lattice's back layer (k = 0) is never keyed; the touch-ups reach most of the rest.
        let lattice: Vec<&str> = still.iter().filter(|s| s.group == "lattice").map(|s| s.name.as_str()).collect();
        let back = lattice.iter().filter(|n| n.as_bytes()[10] == b'0').count();
        assert_eq!(back, 48, "{lattice:?}");
        assert!(lattice.len() <= 48 + 24, "{} lattice controls never move", lattice.len());
        // A few fine shapes no touch-up happened to reach (a production rig has unused
        // shapes too); every other control is animated.
        let odd: Vec<&str> = still
            .iter()
            .filter(|s| !matches!(s.group.as_str(), "tweak" | "lattice" | "shapes_fine"))
            .map(|s| s.name.as_str())
            .collect();
        assert!(odd.is_empty(), "unexpected still controls: {odd:?}");
        let fine = still.iter().filter(|s| s.group == "shapes_fine").count();
        assert!(fine <= 19, "{fine} of 380 fine shapes never move");
    }

    /// Mesh displacement `‖e(p̄ + n·σ_i) − e(p̄)‖` at the good-frame mean, n = 1.
    fn displacement_at_one_sigma(i: usize) -> (f64, f64) {
        let rows = good_rows(None);
        let r = rig();
        let mean: Vec<f64> = (0..r.controls().len()).map(|k| mean_std(&column(&rows, k)).0).collect();
        let (_, sd) = mean_std(&column(&rows, i));
        let base = r.evaluate_vec(&mean);
        let mut p = mean.clone();
        p[i] += sd;
        let moved = r.evaluate_vec(&p);
        let d = base.iter().zip(&moved).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        (sd, d)
    }

    #[test]
    fn large_variance_tiny_effect_controls_exist() {
        let (sd_smile, d_smile) = displacement_at_one_sigma(idx("smile_L"));
        assert!(d_smile > 0.5, "smile moves the mesh: {d_smile}");
        for name in ["tongue_02_rx", "tongue_03_ry", "nostril_L_01_rx", "nostril_R_02_rz"] {
            let i = idx(name);
            assert_eq!(rig().controls()[i].unit, crate::Unit::Degrees);
            let (sd, d) = displacement_at_one_sigma(i);
            assert!(sd > 10.0 && sd > 20.0 * sd_smile, "{name}: std {sd} vs smile {sd_smile}");
            assert!(d < 0.2 * d_smile, "{name}: |Δe| {d} vs smile {d_smile}");
        }
    }

    #[test]
    fn labels_look_like_their_labels() {
        let stat = |label: &str, name: &str| mean_std(&column(&good_rows(Some(label)), idx(name)));
        let max =
            |label: &str, name: &str| column(&good_rows(Some(label)), idx(name)).into_iter().fold(f64::MIN, f64::max);
        // roar opens the jaw wide; surprise drops the jaw and raises brows and upper lids.
        assert!(max("roar", "jaw_open") > 35.0);
        assert!(stat("roar", "jaw_open").0 > 2.0 * stat("neutral", "jaw_open").0 + 5.0);
        assert!(stat("surprise", "brow_up_L").0 > stat("neutral", "brow_up_L").0 + 0.3);
        assert!(stat("surprise", "eye_wide_R").0 > 0.3);
        assert!(max("surprise", "jaw_open") > 15.0);
        assert!(stat("happy", "smile_L").0 > 0.4 && stat("grumpy", "smile_L").0 < 0.05);
        assert!(stat("grumpy", "brow_down_R").0 > 0.4);
        assert!(stat("bored", "eyelid_L_upper_rx").0 > 15.0);
        // head_shake oscillates the head's yaw (neck + head): many direction changes with
        // large swings.
        let yaw_std = |t: &Take| {
            let yaw: Vec<f64> =
                (0..t.frame_count).map(|f| t.frame(f)[idx("head_ry")] + t.frame(f)[idx("neck_ry")]).collect();
            mean_std(&yaw).1
        };
        let neutral_yaw = corpus().takes.iter().filter(|t| t.label == "neutral").map(yaw_std).fold(0.0, f64::max);
        for t in corpus().takes.iter().filter(|t| t.label == "head_shake") {
            let yaw: Vec<f64> =
                (0..t.frame_count).map(|f| t.frame(f)[idx("head_ry")] + t.frame(f)[idx("neck_ry")]).collect();
            let turns =
                yaw.windows(3).filter(|w| (w[1] - w[0]) * (w[2] - w[1]) < 0.0 && (w[1] - w[0]).abs() > 0.5).count();
            let (_, sd) = mean_std(&yaw);
            assert!(turns >= 6 && sd > 2.0 * neutral_yaw, "{}: {turns} turns, std {sd}", t.name);
        }
        // Curious tilts the head more than neutral.
        assert!(stat("curious", "head_rz").1 > stat("neutral", "head_rz").1);
    }

    #[test]
    fn keyed_like_an_animator() {
        let c = rig().controls().len();
        for t in corpus().takes.iter().filter(|t| t.kind == TakeKind::Good) {
            let secs = t.frame_count as f64 / 24.0;
            // Blinks: lids fully close every few seconds, closing fast and opening slower.
            let blink: Vec<f64> = (0..t.frame_count).map(|f| t.frame(f)[idx("eyelid_L_blink")]).collect();
            let closes = blink.windows(2).filter(|w| w[0] < 0.99 && w[1] >= 0.99).count();
            assert!(closes >= 1 && (closes as f64) <= secs / 1.5 + 1.0, "{}: {closes} blinks", t.name);
            // Saccades: eye yaw jumps (> 1° per frame) several times.
            let yaw: Vec<f64> = (0..t.frame_count).map(|f| t.frame(f)[idx("eye_R_yaw")]).collect();
            let jumps = yaw.windows(2).filter(|w| (w[1] - w[0]).abs() > 1.0).count();
            assert!(jumps >= 2, "{}: {jumps} saccade frames", t.name);
            // Moving holds: a coarse shape that moves in the take spends a good share of it
            // creeping (under 0.004 per frame), but is rarely frozen exactly.
            let coarse: Vec<usize> = (0..c)
                .filter(|&i| rig().controls()[i].group == "shapes_coarse")
                .filter(|&i| (1..t.frame_count).any(|f| t.frame(f)[i] != t.frame(0)[i]))
                .collect();
            let share = |pred: &dyn Fn(f64) -> bool| {
                let n = coarse
                    .iter()
                    .flat_map(|&i| (1..t.frame_count).map(move |f| (i, f)))
                    .filter(|&(i, f)| pred((t.frame(f)[i] - t.frame(f - 1)[i]).abs()))
                    .count();
                n as f64 / (coarse.len() * (t.frame_count - 1)) as f64
            };
            let slow = share(&|d| d < 0.004);
            assert!(slow > 0.2, "{}: {slow:.2} of coarse-shape frames in holds", t.name);
        }
        // Ears swing after the head (secondary motion): frame to frame, the ear tips move
        // more than their roots.
        let rows = good_rows(Some("head_shake"));
        let speed = |name: &str| {
            let x = column(&rows, idx(name));
            let d: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
            mean_std(&d).1
        };
        let (root, tip) = (speed("ear_L_01_ry"), speed("ear_L_05_ry"));
        assert!(tip > 1.5 * root, "ear tip speed std {tip}, root {root}");
    }

    #[test]
    fn labels_toml_excludes_exactly_the_bad_data() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../datasets/dragon-face/labels.toml");
        // `REPRISE_BLESS=1 cargo test -p reprise-dragon-face labels_toml` rewrites the file
        // after a change to the corpus; the assertions below then check what was written.
        if std::env::var_os("REPRISE_BLESS").is_some() {
            std::fs::write(path, labels_toml(corpus())).expect("write labels.toml");
        }
        let text = std::fs::read_to_string(path).expect("datasets/dragon-face/labels.toml");
        let doc: toml::Table = text.parse().expect("valid TOML");
        // Every take name matches the rule of its own label first.
        let rules = doc["rule"].as_array().unwrap();
        for t in &corpus().takes {
            let hit = rules
                .iter()
                .find(|r| {
                    let p = r["pattern"].as_str().unwrap();
                    t.name.starts_with(p.trim_end_matches('*'))
                })
                .unwrap();
            assert_eq!(hit["label"].as_str().unwrap(), t.label);
        }
        // Exclusions == bad takes (whole) + bad ranges, nothing more.
        let mut got: Vec<(String, Option<(i64, i64)>)> = doc["exclude"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| {
                assert!(!e["reason"].as_str().unwrap().is_empty());
                let range = e.get("start").map(|s| (s.as_integer().unwrap(), e["end"].as_integer().unwrap()));
                (e["clip"].as_str().unwrap().to_string(), range)
            })
            .collect();
        let mut want = Vec::new();
        for t in &corpus().takes {
            if t.kind != TakeKind::Good {
                want.push((t.name.clone(), None));
            }
            for (a, b, _) in &t.bad_ranges {
                want.push((t.name.clone(), Some((*a as i64, *b as i64))));
            }
        }
        got.sort();
        want.sort();
        assert_eq!(got, want);
        // The file is exactly what labels_toml renders.
        assert_eq!(text, labels_toml(corpus()));
    }

    /// Good takes of `label`, with their usable frame count.
    fn good_takes(label: &str) -> Vec<(&'static Take, usize)> {
        corpus()
            .takes
            .iter()
            .filter(|t| t.label == label && t.kind == TakeKind::Good)
            .map(|t| (t, t.good_frame_count()))
            .collect()
    }

    #[test]
    fn takes_of_a_label_differ_for_real() {
        // Aligned frame by frame, two takes of one label are as far apart as two unrelated
        // draws of the label (RMS difference over the label's std, ≈ √2 for independent
        // takes, ≈ the noise level for a copy with noise), over the keyed coarse controls.
        let specs = rig().controls();
        for label in LABELS {
            let rows = good_rows(Some(label));
            let ctl: Vec<(usize, f64)> = (0..specs.len())
                .filter(|&i| matches!(specs[i].group.as_str(), "shapes_coarse" | "head" | "jaw" | "brows" | "ears"))
                .map(|i| (i, mean_std(&column(&rows, i)).1))
                .filter(|&(_, sd)| sd > 1e-6)
                .collect();
            let takes = good_takes(label);
            for (a, (ta, na)) in takes.iter().enumerate() {
                for (tb, nb) in &takes[a + 1..] {
                    let n = (*na).min(*nb);
                    let rel: f64 = ctl
                        .iter()
                        .map(|&(i, sd)| {
                            let ms = (0..n).map(|f| (ta.frame(f)[i] - tb.frame(f)[i]).powi(2)).sum::<f64>() / n as f64;
                            ms.sqrt() / sd
                        })
                        .sum::<f64>()
                        / ctl.len() as f64;
                    assert!(rel > 0.6, "{} vs {}: mean RMS difference {rel:.2} of the label's std", ta.name, tb.name);
                }
            }
        }
    }

    /// Out-of-sample R² of a least-squares fit of `y` on the columns `x` (plus an
    /// intercept): fitted on the rows where `train` holds, scored on the others. The
    /// normal equations carry a small ridge (the regressors are a few dozen coarse shapes).
    fn heldout_r_squared(x: &[Vec<f64>], y: &[f64], train: &[bool]) -> f64 {
        let k = x.len() + 1;
        let col = |j: usize, r: usize| if j == 0 { 1.0 } else { x[j - 1][r] };
        let mut a = vec![0.0; k * k];
        let mut b = vec![0.0; k];
        for r in (0..y.len()).filter(|&r| train[r]) {
            for i in 0..k {
                b[i] += col(i, r) * y[r];
                for j in 0..=i {
                    a[i * k + j] += col(i, r) * col(j, r);
                }
            }
        }
        for i in 0..k {
            a[i * k + i] += 1e-6 * (1.0 + a[i * k + i]);
            for j in 0..i {
                a[j * k + i] = a[i * k + j];
            }
        }
        // Gaussian elimination (symmetric positive definite: no pivoting needed).
        for p in 0..k {
            for r in p + 1..k {
                let m = a[r * k + p] / a[p * k + p];
                for c in p..k {
                    a[r * k + c] -= m * a[p * k + c];
                }
                b[r] -= m * b[p];
            }
        }
        let mut beta = vec![0.0; k];
        for p in (0..k).rev() {
            let s: f64 = (p + 1..k).map(|c| a[p * k + c] * beta[c]).sum();
            beta[p] = (b[p] - s) / a[p * k + p];
        }
        let test: Vec<usize> = (0..y.len()).filter(|&r| !train[r]).collect();
        let mean = test.iter().map(|&r| y[r]).sum::<f64>() / test.len() as f64;
        let (mut res, mut tot) = (0.0, 0.0);
        for &r in &test {
            let fit: f64 = (0..k).map(|j| beta[j] * col(j, r)).sum();
            res += (y[r] - fit).powi(2);
            tot += (y[r] - mean).powi(2);
        }
        if tot > 0.0 {
            1.0 - res / tot
        } else {
            0.0
        }
    }

    #[test]
    fn fine_shapes_are_not_functions_of_the_coarse_ones() {
        // In dragonface-1 every fine shape was a fixed combination of coarse shapes (±15 %),
        // which a linear fit on some takes predicts on the others (R² ≈ 0.9). Touch-ups
        // keyed on their own are not predictable from the coarse shapes of other takes.
        let specs = rig().controls();
        let rows = good_rows(None);
        // Train on the takes with an even index, score on the odd ones.
        let mut train = Vec::new();
        for (k, t) in corpus().takes.iter().enumerate().filter(|(_, t)| t.kind == TakeKind::Good) {
            train.extend(std::iter::repeat_n(k % 2 == 0, t.good_frame_count()));
        }
        let coarse: Vec<Vec<f64>> = (0..specs.len())
            .filter(|&i| specs[i].group == "shapes_coarse")
            .map(|i| column(&rows, i))
            .filter(|c| mean_std(c).1 > 1e-9)
            .collect();
        let mut r2: Vec<(f64, &str)> = specs
            .iter()
            .enumerate()
            .filter(|(i, s)| s.group == "shapes_fine" && mean_std(&column(&rows, *i)).1 > 1e-6)
            .map(|(i, s)| (heldout_r_squared(&coarse, &column(&rows, i), &train), s.name.as_str()))
            .collect();
        r2.sort_by(|a, b| a.0.total_cmp(&b.0));
        let median = r2[r2.len() / 2].0;
        let high = r2.iter().filter(|r| r.0 > 0.5).count();
        println!(
            "held-out R² of fine on coarse: median {median:.2}, {high} of {} above 0.5, worst {:?}",
            r2.len(),
            r2.last()
        );
        assert!(median < 0.2 && high * 20 < r2.len(), "median R² {median:.2}, {high} above 0.5, worst {:?}", r2.last());
    }

    #[test]
    fn every_frame_is_a_sane_mesh() {
        // Each vertex stays near its rest position: within 40 % of the rest mesh's
        // bounding-box diagonal on the head, eyes and tongue (the head turned 40° moves the
        // snout tip about a third of it), 60 % on the ears (long chains that swing).
        let r = rig();
        let rest = r.rest_positions();
        let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
        for p in rest.chunks_exact(3) {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
        let mut out = vec![0.0; rest.len()];
        let parts = r.parts();
        let mut worst = vec![0.0f64; parts.len()];
        for row in good_rows(None) {
            r.evaluate(row, &mut out);
            for (k, (_, range)) in parts.iter().enumerate() {
                for v in range.clone() {
                    let d = (0..3).map(|a| (out[3 * v + a] - rest[3 * v + a]).powi(2)).sum::<f64>().sqrt();
                    assert!(d.is_finite());
                    worst[k] = worst[k].max(d);
                }
            }
        }
        for ((part, _), w) in parts.iter().zip(&worst) {
            let bound = if part.starts_with("ear") { 0.6 } else { 0.4 } * diag;
            assert!(*w < bound, "a vertex of {part} moved {w:.2} cm (bound {bound:.2} cm)");
            println!("{part}: largest vertex displacement {w:.2} cm (bound {bound:.2} cm)");
        }
    }

    #[test]
    #[ignore = "benchmark: cargo test --release -p reprise-dragon-face -- --ignored --nocapture"]
    fn bench_generate_corpus() {
        let r = rig();
        let t = std::time::Instant::now();
        let c = generate_corpus(r, 7);
        println!("generate_corpus: {:.1} ms, {} takes", t.elapsed().as_secs_f64() * 1e3, c.takes.len());
    }

    #[test]
    #[ignore = "diagnostics"]
    fn debug_corpus_stats() {
        let r = rig();
        let c = corpus();
        for t in &c.takes {
            println!(
                "{} {:?} frames {} good {} {:?}",
                t.name,
                t.kind,
                t.frame_count,
                t.good_frame_count(),
                t.exclusion
            );
        }
        let rows = good_rows(None);
        let mut clamped: HashMap<&str, usize> = HashMap::new();
        for (i, s) in r.controls().iter().enumerate() {
            let col = column(&rows, i);
            let n = col.iter().filter(|&&x| x == s.min || x == s.max).count();
            *clamped.entry(s.group.as_str()).or_default() += n;
            if [
                "jaw_open",
                "head_ry",
                "ear_L_05_rx",
                "ear_L_05_ry",
                "eye_L_yaw",
                "eyelid_L_blink",
                "smile_L",
                "tongue_02_rx",
                "lip_upper_03_up",
                "brow_L_mid_ty",
                "lattice_113_tz",
                "head_rx",
            ]
            .contains(&s.name.as_str())
            {
                let (m, sd) = mean_std(&col);
                let (lo, hi) = col.iter().fold((f64::MAX, f64::MIN), |a, &x| (a.0.min(x), a.1.max(x)));
                println!("{:>16}: mean {m:8.3} std {sd:8.3} [{lo:.2}, {hi:.2}] at-limit {n}", s.name);
            }
        }
        println!("frames at a limit, by group: {clamped:?}");
    }
}
