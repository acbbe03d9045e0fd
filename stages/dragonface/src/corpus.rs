//! The hand-keyed animation corpus: eight labels, several takes each, 3,745 good frames at
//! 24 fps, plus bad takes and bad frame ranges that labeling must exclude.
//!
//! A take is built like an animator builds a shot: a key schedule of poses from the label's
//! library (mixed and amplitude-varied per take), held keys, flat-tangent eases, an
//! anticipation key before and an overshoot key after big moves; head and ears sampled a
//! few frames late (overlapping action); then layers: breathing, label actions (head-shake
//! oscillation, roar tremble), ear secondary motion from a damped spring driven by the
//! head's angular acceleration, blinks and eye saccades. Good takes are clamped to ranges.

use crate::controls::{EAR_BONES, LATTICE_N, SIDES};
use crate::keys::{acceleration, blink_starts, saccades, spring_response, Blink, PoseKeys};
use crate::poses::{key_pose, style, Style};
use crate::rig::DragonRig;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

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

/// Indices of controls by role, for sampling with different lags.
struct Roles {
    head: Vec<usize>,
    ears: Vec<usize>,
    face: Vec<usize>,
    /// Controls that move the whole mesh a lot; big changes get anticipation/overshoot.
    main: Vec<usize>,
}

fn roles(rig: &DragonRig) -> Roles {
    let mut r = Roles { head: vec![], ears: vec![], face: vec![], main: vec![] };
    for (i, s) in rig.controls().iter().enumerate() {
        match s.group.as_str() {
            "head" => r.head.push(i),
            "ears" => r.ears.push(i),
            "eyes" if !s.name.ends_with("_dilate") => {}
            _ => r.face.push(i),
        }
        if s.group == "head" || s.group == "shapes_coarse" || s.name == "jaw_open" {
            r.main.push(i);
        }
    }
    r
}

fn ctl(rig: &DragonRig, name: &str) -> usize {
    rig.control_index(name).unwrap_or_else(|| panic!("no control {name}"))
}

/// Animate one good take of `frames` frames; returns row-major values.
fn animate(rig: &DragonRig, label: &str, frames: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let st = style(label);
    let c = rig.controls().len();
    let defaults = rig.default_pose();
    let ro = roles(rig);
    let mood = Mood {
        amp: rng.gen_range(0.85..1.15),
        tempo: rng.gen_range(0.85..1.2),
        yaw_bias: rng.gen_range(-10.0..10.0),
        gaze: (rng.gen_range(-8.0..8.0), rng.gen_range(-4.0..4.0)),
    };
    let keys = key_schedule(rig, label, frames, &st, &mood, &ro, &defaults, rng);
    let lag_head = rng.gen_range(1.0..4.0);
    let lag_ears = rng.gen_range(2.0..5.0);
    let mut v = vec![0.0; frames * c];
    for f in 0..frames {
        let row = &mut v[f * c..(f + 1) * c];
        let t = f as f64;
        keys.sample_into(t, &ro.face, row);
        keys.sample_into(t - lag_head, &ro.head, row);
        keys.sample_into(t - lag_ears, &ro.ears, row);
    }
    // Staging offset and breathing.
    let period = rng.gen_range(3.0..4.5) * FPS;
    let phase = rng.gen_range(0.0..2.0 * PI);
    let (hry, hty, nrx) = (ctl(rig, "head_ry"), ctl(rig, "head_ty"), ctl(rig, "neck_rx"));
    for (f, row) in v.chunks_exact_mut(c).enumerate() {
        let b = (2.0 * PI * f as f64 / period + phase).sin() * st.breath;
        row[hry] += mood.yaw_bias;
        row[hty] += 0.12 * b;
        row[nrx] += 0.5 * b;
    }
    if label == "head_shake" {
        head_shake_layer(rig, &mut v, frames, rng);
    }
    if label == "roar" {
        let (jaw, hrx) = (ctl(rig, "jaw_open"), ctl(rig, "head_rx"));
        let ph = rng.gen_range(0.0..2.0 * PI);
        for f in 0..frames {
            let k = crate::math::smoothstep(25.0, 35.0, v[f * c + jaw]);
            let t = f as f64 / FPS;
            v[f * c + hrx] += 1.2 * k * (2.0 * PI * 8.0 * t + ph).sin();
            v[f * c + jaw] += 1.5 * k * (2.0 * PI * 6.0 * t + ph + 1.0).sin();
        }
    }
    ear_secondary(rig, &mut v, frames);
    blinks(rig, &mut v, frames, &st, rng);
    eyes(rig, &mut v, frames, &st, &mood, rng);
    for row in v.chunks_exact_mut(c) {
        clamp_pose(rig, row);
    }
    v
}

/// Key poses on a sparse schedule with holds, anticipation and overshoot.
#[allow(clippy::too_many_arguments)]
fn key_schedule(
    rig: &DragonRig,
    label: &str,
    frames: usize,
    st: &Style,
    mood: &Mood,
    ro: &Roles,
    defaults: &[f64],
    rng: &mut ChaCha8Rng,
) -> PoseKeys {
    let specs = rig.controls();
    let next_pose = |first: bool, rng: &mut ChaCha8Rng| {
        let mut p = key_pose(rig, label, first, rng);
        if !first && rng.gen_bool(0.35) {
            let q = key_pose(rig, label, false, rng);
            let a = rng.gen_range(0.2..0.5);
            p.iter_mut().zip(&q).for_each(|(x, y)| *x += a * (y - *x));
        }
        let amp = mood.amp * rng.gen_range(0.92..1.08);
        p.iter_mut().zip(defaults).for_each(|(x, d)| *x = d + amp * (*x - d));
        p
    };
    let mut keys = PoseKeys::default();
    let mut cur = next_pose(true, rng);
    keys.push(0.0, cur.clone());
    let mut t = 0.0;
    let end = frames as f64 + 8.0;
    while t < end {
        t += rng.gen_range(st.hold_frames.0..st.hold_frames.1) * mood.tempo;
        keys.push(t, cur.clone());
        let next = next_pose(false, rng);
        let mv = rng.gen_range(st.move_frames.0..st.move_frames.1) * mood.tempo;
        let big = ro.main.iter().any(|&i| (next[i] - cur[i]).abs() / (specs[i].max - specs[i].min) > 0.15);
        if big {
            let a = st.anticipation * rng.gen_range(0.7..1.3);
            let o = st.overshoot * rng.gen_range(0.7..1.3);
            let antic: Vec<f64> = cur.iter().zip(&next).map(|(c, n)| c + a * (c - n)).collect();
            t += rng.gen_range(3.0..5.0);
            keys.push(t, antic);
            let over: Vec<f64> = cur.iter().zip(&next).map(|(c, n)| n + o * (n - c)).collect();
            t += mv;
            keys.push(t, over);
            t += rng.gen_range(3.0..6.0);
        } else {
            t += mv;
        }
        keys.push(t, next.clone());
        cur = next;
    }
    keys
}

/// head_shake: bursts of yaw oscillation (2–3 Hz, ±16–26°) with eased attack and decay.
fn head_shake_layer(rig: &DragonRig, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let (hry, nry, hrz) = (ctl(rig, "head_ry"), ctl(rig, "neck_ry"), ctl(rig, "head_rz"));
    let mut start = rng.gen_range(3..14);
    while start + 12 < frames {
        let dur = rng.gen_range(30..54).min(frames - start);
        let amp = rng.gen_range(16.0..26.0);
        let freq = rng.gen_range(2.0..3.0);
        for tau in 0..dur {
            let x = tau as f64;
            let env = crate::keys::ease(x / 5.0) * (1.0 - x / dur as f64).powf(0.7);
            let s = amp * env * (2.0 * PI * freq * x / FPS).sin();
            let f = start + tau;
            v[f * c + hry] += s;
            v[f * c + nry] += 0.3 * s;
            v[f * c + hrz] += 0.1 * s;
        }
        start += dur + rng.gen_range(10..24);
    }
}

/// Ears lag the head: a damped spring (2.2 Hz, ζ = 0.3) per axis driven by minus the head's
/// angular acceleration (neck + head), stronger towards the ear tips.
fn ear_secondary(rig: &DragonRig, v: &mut [f64], frames: usize) {
    let c = rig.controls().len();
    let omega = 2.0 * PI * 2.2 / FPS;
    for (axis, ax) in ["rx", "ry", "rz"].iter().enumerate() {
        let (n, h) = (ctl(rig, &format!("neck_{ax}")), ctl(rig, &format!("head_{ax}")));
        let angle: Vec<f64> = (0..frames).map(|f| v[f * c + n] + v[f * c + h]).collect();
        let drive: Vec<f64> = acceleration(&angle).iter().map(|a| -a).collect();
        let resp = spring_response(&drive, omega, 0.3, 4);
        for (s, sx) in SIDES {
            for b in 0..EAR_BONES {
                let i = ctl(rig, &format!("ear_{s}_{:02}_{ax}", b + 1));
                // ry/rz are mirrored on the right ear; physical lag is the same direction.
                let gain = (0.15 + 0.12 * b as f64) * if axis == 0 { 1.0 } else { sx };
                for f in 0..frames {
                    v[f * c + i] += gain * resp[f];
                }
            }
        }
    }
}

/// Blinks: both lids close over ~2 frames and open over ~4, every `blink_gap` frames.
fn blinks(rig: &DragonRig, v: &mut [f64], frames: usize, st: &Style, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let ids = [ctl(rig, "eyelid_L_blink"), ctl(rig, "eyelid_R_blink")];
    for start in blink_starts(frames, st.blink_gap, rng) {
        let b = Blink { close: st.blink_close, hold: rng.gen_range(0..=1) as f64, open: st.blink_open };
        let lag = [0.0, if rng.gen_bool(0.2) { 1.0 } else { 0.0 }];
        for f in start..(start + b.length().ceil() as usize + 2).min(frames) {
            for (k, &i) in ids.iter().enumerate() {
                let x = b.value(f as f64 - start as f64 - lag[k]);
                v[f * c + i] = v[f * c + i].max(x);
            }
        }
    }
}

/// Eye saccades plus partial counter-rotation against head yaw/pitch; slight vergence.
fn eyes(rig: &DragonRig, v: &mut [f64], frames: usize, st: &Style, mood: &Mood, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let gaze = saccades(frames, st.saccade_gap, st.saccade_range, mood.gaze, rng);
    let verg = rng.gen_range(0.0..2.0);
    let (nry, hry, nrx, hrx) = (ctl(rig, "neck_ry"), ctl(rig, "head_ry"), ctl(rig, "neck_rx"), ctl(rig, "head_rx"));
    let ids =
        [(ctl(rig, "eye_L_yaw"), ctl(rig, "eye_L_pitch"), -1.0), (ctl(rig, "eye_R_yaw"), ctl(rig, "eye_R_pitch"), 1.0)];
    for (f, &(gy, gp)) in gaze.iter().enumerate() {
        let row = &mut v[f * c..(f + 1) * c];
        let hy = row[nry] + row[hry];
        let hp = row[nrx] + row[hrx];
        for &(y, p, s) in &ids {
            row[y] = gy - 0.2 * hy + s * verg;
            // head pitch down (positive) makes the eyes look up a little to compensate
            row[p] = gp + 0.2 * hp;
        }
    }
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
        let lattice = still.iter().filter(|s| s.group == "lattice").count();
        assert!(lattice >= 144, "{lattice} lattice controls never move");
        let odd: Vec<&str> =
            still.iter().filter(|s| s.group != "tweak" && s.group != "lattice").map(|s| s.name.as_str()).collect();
        assert!(odd.is_empty(), "unexpected still controls: {odd:?}");
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
        // head_shake oscillates the head's yaw: many direction changes with large swings.
        for t in corpus().takes.iter().filter(|t| t.label == "head_shake") {
            let yaw: Vec<f64> = (0..t.frame_count).map(|f| t.frame(f)[idx("head_ry")]).collect();
            let turns =
                yaw.windows(3).filter(|w| (w[1] - w[0]) * (w[2] - w[1]) < 0.0 && (w[1] - w[0]).abs() > 0.5).count();
            let (_, sd) = mean_std(&yaw);
            assert!(turns >= 6 && sd > 5.0, "{}: {turns} turns, std {sd}", t.name);
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
            // Holds: the coarse shapes stay put for stretches of >= 4 frames.
            let coarse: Vec<usize> = (0..c).filter(|&i| rig().controls()[i].group == "shapes_coarse").collect();
            let still = (1..t.frame_count)
                .filter(|&f| coarse.iter().all(|&i| (t.frame(f)[i] - t.frame(f - 1)[i]).abs() < 1e-9))
                .count();
            assert!(still as f64 > 0.2 * t.frame_count as f64, "{}: {still} held frames", t.name);
        }
        // Ears swing after the head (secondary motion): the ear tips move more than their roots.
        let rows = good_rows(Some("head_shake"));
        let (_, root) = mean_std(&column(&rows, idx("ear_L_01_ry")));
        let (_, tip) = mean_std(&column(&rows, idx("ear_L_05_ry")));
        assert!(tip > 1.5 * root && tip > 3.0, "ear tip std {tip}, root {root}");
    }

    #[test]
    fn labels_toml_excludes_exactly_the_bad_data() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../datasets/dragon-face/labels.toml");
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

    #[test]
    #[ignore = "benchmark: cargo test --release -p reprise-dragonface -- --ignored --nocapture"]
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
