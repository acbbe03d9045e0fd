//! Control groups that an animator keys on their own timing.
//!
//! A face is not keyed as one pose after another: the neck leads and the head follows, the
//! jaw has its own beats, one brow goes up before the other, the ears settle late. Each
//! [`Part`] is a set of controls with its own key schedule (own holds, moves, tempo and
//! start offset); its keys draw fresh poses from the label's library, so the parts of one
//! take overlap and break successively instead of moving in lockstep. A sided part's right
//! half follows the left half's timing a few frames late and mixes in a pose of its own, so
//! the two sides are related but never mirror images.

use crate::keys::PoseKeys;
use crate::poses::{key_pose, Style};
use crate::rig::DragonRig;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// A set of controls keyed together. `right` is empty for a part without sides.
pub(crate) struct Part {
    pub name: &'static str,
    /// Controls of the part (the left half of a sided part, and its centre controls).
    pub left: Vec<usize>,
    /// The right half of a sided part.
    pub right: Vec<usize>,
}

/// Which part a control belongs to (`None`: not keyed through a part — blinks, gaze,
/// fine shapes, lattice and tweak offsets come from layers of their own).
fn part_of(name: &str, group: &str) -> Option<&'static str> {
    let starts = |p: &[&str]| p.iter().any(|s| name.starts_with(s));
    Some(match group {
        "head" if name.starts_with("neck") => "neck",
        "head" => "head",
        "jaw" => "jaw",
        "tongue" => "tongue",
        "nostrils" => "nostrils",
        "ears" => "ears",
        "brows" => "brows",
        "eyelids" if name.ends_with("_blink") => return None,
        "eyelids" => "lids",
        "eyes" if name.ends_with("_dilate") => "pupils",
        "eyes" => return None,
        "shapes_coarse" => {
            if starts(&["jaw_open_shape", "chin_raise", "lower_lip_depress"]) {
                "jaw"
            } else if starts(&["squint", "eye_wide"]) {
                "lids"
            } else if starts(&["forehead_raise"]) {
                "brows"
            } else if starts(&["cheek_", "nose_wrinkle", "jowl", "snout_scrunch"]) {
                "cheeks"
            } else if starts(&["lip_", "mouth_left", "mouth_right", "throat_swallow"]) {
                "lips"
            } else {
                "mouth"
            }
        }
        _ => return None,
    })
}

/// Whether a control name belongs to the character's right side (`_R` as a name token).
fn is_right(name: &str) -> bool {
    name.split('_').any(|t| t == "R")
}

/// The parts of the rig, in a fixed order.
pub(crate) fn parts(rig: &DragonRig) -> Vec<Part> {
    const ORDER: [&str; 12] =
        ["neck", "head", "jaw", "mouth", "lips", "cheeks", "brows", "lids", "ears", "pupils", "tongue", "nostrils"];
    const SIDED: [&str; 6] = ["mouth", "cheeks", "brows", "lids", "ears", "pupils"];
    let mut out: Vec<Part> = ORDER.iter().map(|&name| Part { name, left: vec![], right: vec![] }).collect();
    for (i, s) in rig.controls().iter().enumerate() {
        if let Some(p) = part_of(&s.name, &s.group) {
            let part = out.iter_mut().find(|q| q.name == p).expect("part in ORDER");
            if SIDED.contains(&p) && is_right(&s.name) {
                part.right.push(i);
            } else {
                part.left.push(i);
            }
        }
    }
    out
}

/// Per-take settings of one part: how strongly and how fast it is played.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PartMood {
    /// Amplitude of the part's keys about the default pose.
    pub amp: f64,
    /// Multiplier of the label's hold and move durations.
    pub tempo: f64,
}

/// Everything a part's schedule depends on besides the random stream.
pub(crate) struct ScheduleSpec<'a> {
    pub rig: &'a DragonRig,
    pub label: &'a str,
    pub style: &'a Style,
    pub mood: PartMood,
    /// Frames to cover (keys run a little past the end).
    pub frames: usize,
    /// Controls whose relative change marks a big move (anticipation and overshoot).
    pub main: &'a [usize],
}

/// One part's key schedule: key poses drawn from the label's library on the part's own
/// clock. Between keys: a hold that drifts (a moving hold: the pose creeps 4–15 % of the
/// way toward another library pose, so nothing is frozen), then a move; big moves get an
/// anticipation key before and an overshoot key after.
pub(crate) fn schedule(spec: &ScheduleSpec<'_>, rng: &mut ChaCha8Rng) -> PoseKeys {
    let (rig, st, mood) = (spec.rig, spec.style, spec.mood);
    let specs = rig.controls();
    let defaults = rig.default_pose();
    let draw = |first: bool, rng: &mut ChaCha8Rng| {
        let mut p = key_pose(rig, spec.label, first, rng);
        if !first && rng.gen_bool(0.35) {
            let q = key_pose(rig, spec.label, false, rng);
            let a = rng.gen_range(0.2..0.5);
            p.iter_mut().zip(&q).for_each(|(x, y)| *x += a * (y - *x));
        }
        let amp = mood.amp * rng.gen_range(0.9..1.1);
        p.iter_mut().zip(&defaults).for_each(|(x, d)| *x = d + amp * (*x - d));
        p
    };
    let mut keys = PoseKeys::default();
    let mut cur = draw(true, rng);
    // Parts start out of phase: the first key lies up to one hold before frame 0.
    let mut t = -rng.gen_range(0.0..st.hold_frames.1 * mood.tempo);
    keys.push(t, cur.clone());
    let end = spec.frames as f64 + 8.0;
    while t < end {
        t += rng.gen_range(st.hold_frames.0..st.hold_frames.1) * mood.tempo;
        let drift = draw(false, rng);
        let h = rng.gen_range(0.04..0.15);
        cur.iter_mut().zip(&drift).for_each(|(c, d)| *c += h * (d - *c));
        keys.push(t, cur.clone());
        let next = draw(false, rng);
        let mv = rng.gen_range(st.move_frames.0..st.move_frames.1) * mood.tempo;
        let big = spec.main.iter().any(|&i| (next[i] - cur[i]).abs() / (specs[i].max - specs[i].min) > 0.15);
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

/// The right half of a sided part: the left schedule's keys `lag` frames later, each
/// mixed a share `mix` (per key, drawn from the range) toward a pose of its own.
pub(crate) fn right_side(
    left: &PoseKeys,
    lag: f64,
    mix: (f64, f64),
    spec: &ScheduleSpec<'_>,
    rng: &mut ChaCha8Rng,
) -> PoseKeys {
    let mut keys = PoseKeys::default();
    let defaults = spec.rig.default_pose();
    for (t, pose) in left.frames.iter().zip(&left.poses) {
        let own = key_pose(spec.rig, spec.label, false, rng);
        let a = rng.gen_range(mix.0..mix.1);
        let amp = spec.mood.amp;
        let p: Vec<f64> =
            pose.iter().zip(&own).zip(&defaults).map(|((l, o), d)| l + a * (d + amp * (o - d) - l)).collect();
        keys.push(t + lag, p);
    }
    keys
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_partition_the_keyed_controls() {
        let rig = DragonRig::new(7);
        let ps = parts(&rig);
        let mut seen = vec![0usize; rig.controls().len()];
        for p in &ps {
            assert!(!p.left.is_empty(), "{}", p.name);
            for &i in p.left.iter().chain(&p.right) {
                seen[i] += 1;
            }
            for &i in &p.right {
                assert!(is_right(&rig.controls()[i].name));
            }
        }
        for (s, n) in rig.controls().iter().zip(&seen) {
            let layered = matches!(s.group.as_str(), "shapes_fine" | "lattice" | "tweak")
                || s.name.ends_with("_blink")
                || s.name.ends_with("_yaw")
                || s.name.ends_with("_pitch");
            assert_eq!(*n, usize::from(!layered), "{}", s.name);
        }
        let ears = ps.iter().find(|p| p.name == "ears").unwrap();
        assert_eq!((ears.left.len(), ears.right.len()), (15, 15));
        assert!(is_right("brow_R_inner_ty") && is_right("smile_R") && !is_right("brow_L_mid_rz"));
        assert!(!is_right("mouth_right"), "mouth_right is a centre control");
    }
}
