//! Layers added on top of the keyed parts: what an animator animates as overlapping
//! cycles or physics rather than as key poses. Breathing (head, neck, jaw, nostrils), the
//! head-shake and roar cycles, muttering and snarling beats on the jaw and lips, damped
//! secondary motion of the ears and cheeks, blinks and eye saccades. Every layer reads and
//! writes the row-major `frames × C` value buffer of one take; time is in frames (24 fps).

use crate::controls::{EAR_BONES, SIDES};
use crate::corpus::FPS;
use crate::keys::{acceleration, blink_starts, ease, saccades, spring_response, Blink};
use crate::poses::Style;
use crate::rig::DragonRig;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

fn ctl(rig: &DragonRig, name: &str) -> usize {
    rig.control_index(name).unwrap_or_else(|| panic!("no control {name}"))
}

/// Staging offset of the head's yaw and breathing: a 3–4.5 s cycle raising the head,
/// tipping the neck, parting the jaw (up to 0.8° at the label's breath depth) and flaring
/// the nostrils a little.
pub(crate) fn breathing(rig: &DragonRig, v: &mut [f64], style: &Style, yaw_bias: f64, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let period = rng.gen_range(3.0..4.5) * FPS;
    let phase = rng.gen_range(0.0..2.0 * PI);
    let (hry, hty, nrx, jaw) = (ctl(rig, "head_ry"), ctl(rig, "head_ty"), ctl(rig, "neck_rx"), ctl(rig, "jaw_open"));
    let flare = [ctl(rig, "nostril_seg_L_01_flare"), ctl(rig, "nostril_seg_R_01_flare")];
    for (f, row) in v.chunks_exact_mut(c).enumerate() {
        let b = (2.0 * PI * f as f64 / period + phase).sin() * style.breath;
        row[hry] += yaw_bias;
        row[hty] += 0.12 * b;
        row[nrx] += 0.5 * b;
        row[jaw] += 0.4 * (b + style.breath);
        for &i in &flare {
            row[i] += 0.06 * (b + style.breath);
        }
    }
}

/// head_shake: bursts of yaw oscillation (2–3 Hz, ±7–12°) with eased attack and decay.
/// The neck leads and the head follows 1–2.5 frames later (successive breaking), with a
/// roll of its own phase and a little pitch bob.
pub(crate) fn head_shake(rig: &DragonRig, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let (hry, nry, hrz, hrx) = (ctl(rig, "head_ry"), ctl(rig, "neck_ry"), ctl(rig, "head_rz"), ctl(rig, "head_rx"));
    let mut start = rng.gen_range(3..14);
    while start + 12 < frames {
        let dur = rng.gen_range(30..54).min(frames - start);
        let amp = rng.gen_range(7.0..12.0);
        let freq = rng.gen_range(2.0..3.0);
        let lag = rng.gen_range(1.0..2.5);
        let (roll, roll_lag, bob) = (rng.gen_range(0.1..0.35), rng.gen_range(0.0..3.0), rng.gen_range(0.0..0.15));
        let wave = |x: f64| {
            let env = ease(x / 5.0) * (1.0 - x / dur as f64).clamp(0.0, 1.0).powf(0.7);
            amp * env * (2.0 * PI * freq * x / FPS).sin()
        };
        for tau in 0..dur {
            let x = tau as f64;
            let f = start + tau;
            v[f * c + nry] += 0.5 * wave(x);
            v[f * c + hry] += 0.5 * wave(x - lag);
            v[f * c + hrz] += roll * wave(x - lag - roll_lag);
            v[f * c + hrx] += bob * wave(2.0 * x).abs();
        }
        start += dur + rng.gen_range(10..24);
    }
}

/// Ear flicks, a creature's tic: one ear twitches back or out by 10–25° over 2–3 frames
/// and settles over 6–12, a few times a minute per ear (label-dependent), tip leading.
pub(crate) fn ear_flicks(rig: &DragonRig, label: &str, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let rate = match label {
        "curious" | "surprise" | "roar" => 0.35,
        "neutral" | "bored" | "happy" => 0.25,
        _ => 0.15,
    };
    let c = rig.controls().len();
    for (s, _) in SIDES {
        let mut t = rng.gen_range(0.0..1.0 / rate) * FPS;
        while (t as usize) < frames {
            let (up, out) =
                (rng.gen_range(10.0..25.0) * if rng.gen_bool(0.6) { -1.0 } else { 1.0 }, rng.gen_range(-8.0..8.0));
            let (rise, fall) = (rng.gen_range(2.0..3.0), rng.gen_range(6.0..12.0));
            let f0 = t as usize;
            for f in f0..(f0 + (rise + fall) as usize + 2).min(frames) {
                let x = (f - f0) as f64;
                let env = if x < rise { ease(x / rise) } else { 1.0 - ease((x - rise) / fall) };
                for b in 0..EAR_BONES {
                    let g = 0.6 + 0.15 * b as f64;
                    v[f * c + ctl(rig, &format!("ear_{s}_{:02}_rx", b + 1))] += g * up * env;
                    v[f * c + ctl(rig, &format!("ear_{s}_{:02}_ry", b + 1))] += g * out * env;
                }
            }
            t += rng.gen_range(0.4..1.6) / rate * FPS;
        }
    }
}

/// roar: an 8 Hz tremble of the head and a 6 Hz shudder of the jaw while it is wide open.
pub(crate) fn roar_tremble(rig: &DragonRig, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let (jaw, hrx) = (ctl(rig, "jaw_open"), ctl(rig, "head_rx"));
    let ph = rng.gen_range(0.0..2.0 * PI);
    for f in 0..frames {
        let k = crate::math::smoothstep(25.0, 35.0, v[f * c + jaw]);
        let t = f as f64 / FPS;
        v[f * c + hrx] += 1.2 * k * (2.0 * PI * 8.0 * t + ph).sin();
        v[f * c + jaw] += 1.5 * k * (2.0 * PI * 6.0 * t + ph + 1.0).sin();
    }
}

/// How often a label mutters (bursts per second) and how widely the jaw moves (degrees).
fn mutter_style(label: &str) -> Option<(f64, f64)> {
    match label {
        "grumpy" => Some((0.25, 5.0)),
        "bored" => Some((0.12, 3.0)),
        "neutral" => Some((0.25, 4.0)),
        "head_shake" => Some((0.2, 4.0)),
        "curious" => Some((0.1, 3.5)),
        "happy" => Some((0.12, 5.0)),
        _ => None,
    }
}

/// Muttering: bursts of 0.6–2 s in which the jaw opens and closes on syllables (3.5–6 Hz,
/// rectified so it only opens), the lips press and pucker against it, one corner pulled.
pub(crate) fn muttering(rig: &DragonRig, label: &str, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let Some((rate, depth)) = mutter_style(label) else { return };
    let c = rig.controls().len();
    let (jaw, press, pucker) = (ctl(rig, "jaw_open"), ctl(rig, "lip_press"), ctl(rig, "lip_pucker"));
    let corners = [ctl(rig, "mouth_wide_L"), ctl(rig, "mouth_wide_R")];
    let mut t = rng.gen_range(0.0..1.0 / rate) * FPS;
    while (t as usize) < frames {
        let dur = rng.gen_range(0.6..2.0) * FPS;
        let freq = rng.gen_range(3.5..6.0);
        let a = depth * rng.gen_range(0.5..1.2);
        let corner = corners[rng.gen_range(0..2)];
        let (f0, f1) = (t as usize, ((t + dur) as usize).min(frames));
        for f in f0..f1 {
            let x = (f - f0) as f64;
            let env = ease(x / 4.0) * ease((f1 - f) as f64 / 4.0);
            let s = (2.0 * PI * freq * x / FPS).sin();
            v[f * c + jaw] += a * env * s.max(0.0);
            v[f * c + press] += 0.25 * env * (-s).max(0.0);
            v[f * c + pucker] += 0.15 * env * (0.5 + 0.5 * (2.0 * PI * 0.5 * freq * x / FPS).sin());
            v[f * c + corner] += 0.12 * env;
        }
        t += dur + rng.gen_range(0.5..2.0) / rate * FPS;
    }
}

/// Snarling beats (grumpy, roar, head_shake): one side's upper lip lifts with the nose
/// wrinkle and the jaw parts a few degrees, held 0.3–0.8 s.
pub(crate) fn snarls(rig: &DragonRig, label: &str, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let rate = match label {
        "grumpy" => 0.15,
        "roar" => 0.25,
        "head_shake" => 0.08,
        _ => return,
    };
    let c = rig.controls().len();
    let jaw = ctl(rig, "jaw_open");
    let mut t = rng.gen_range(0.0..1.0 / rate) * FPS;
    while (t as usize) < frames {
        let (s, _) = SIDES[rng.gen_range(0..2)];
        let (lip, nose) = (ctl(rig, &format!("upper_lip_raise_{s}")), ctl(rig, &format!("nose_wrinkle_{s}")));
        let dur = rng.gen_range(0.3..0.8) * FPS;
        let (a, j) = (rng.gen_range(0.3..0.8), rng.gen_range(2.0..7.0));
        let (f0, f1) = (t as usize, ((t + dur + 8.0) as usize).min(frames));
        for f in f0..f1 {
            let x = (f - f0) as f64;
            let env = ease(x / 4.0) * ease((dur + 8.0 - x) / 6.0);
            v[f * c + lip] += a * env;
            v[f * c + nose] += 0.7 * a * env;
            v[f * c + jaw] += j * env;
        }
        t += dur + rng.gen_range(0.5..2.0) / rate * FPS;
    }
}

/// Ears lag the head: a damped spring (2.2 Hz, ζ = 0.3) per axis driven by minus the head's
/// angular acceleration (neck + head), stronger towards the ear tips; the two ears get
/// slightly different gains (one ear is always a little floppier).
pub(crate) fn ear_secondary(rig: &DragonRig, v: &mut [f64], frames: usize, rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let omega = 2.0 * PI * 2.2 / FPS;
    let side_gain = [rng.gen_range(0.8..1.2), rng.gen_range(0.8..1.2)];
    for (axis, ax) in ["rx", "ry", "rz"].iter().enumerate() {
        let (n, h) = (ctl(rig, &format!("neck_{ax}")), ctl(rig, &format!("head_{ax}")));
        let angle: Vec<f64> = (0..frames).map(|f| v[f * c + n] + v[f * c + h]).collect();
        let drive: Vec<f64> = acceleration(&angle).iter().map(|a| -a).collect();
        let resp = spring_response(&drive, omega, 0.3, 4);
        for (side, (s, sx)) in SIDES.into_iter().enumerate() {
            for b in 0..EAR_BONES {
                let i = ctl(rig, &format!("ear_{s}_{:02}_{ax}", b + 1));
                // ry/rz are mirrored on the right ear; physical lag is the same direction.
                let gain = side_gain[side] * (0.15 + 0.12 * b as f64) * if axis == 0 { 1.0 } else { sx };
                for f in 0..frames {
                    v[f * c + i] += gain * resp[f];
                }
            }
        }
    }
}

/// Cheeks jiggle: a damped spring (3 Hz, ζ = 0.35) driven by the jaw's and the head's pitch
/// accelerations, pushing the lower cheek fine shapes out (positive) or in (negative).
pub(crate) fn cheek_secondary(rig: &DragonRig, v: &mut [f64], frames: usize) {
    let c = rig.controls().len();
    let omega = 2.0 * PI * 3.0 / FPS;
    let (jaw, nrx, hrx) = (ctl(rig, "jaw_open"), ctl(rig, "neck_rx"), ctl(rig, "head_rx"));
    let drive: Vec<f64> = {
        let j: Vec<f64> = (0..frames).map(|f| v[f * c + jaw]).collect();
        let h: Vec<f64> = (0..frames).map(|f| v[f * c + nrx] + v[f * c + hrx]).collect();
        acceleration(&j).iter().zip(acceleration(&h)).map(|(a, b)| 0.02 * a + 0.015 * b).collect()
    };
    let resp = spring_response(&drive, omega, 0.35, 4);
    for (s, _) in SIDES {
        for seg in 5..=8 {
            let (out, inn) =
                (ctl(rig, &format!("cheek_{s}_{seg:02}_out")), ctl(rig, &format!("cheek_{s}_{seg:02}_in")));
            for f in 0..frames {
                v[f * c + out] += resp[f].max(0.0);
                v[f * c + inn] += (-resp[f]).max(0.0);
            }
        }
    }
}

/// Blinks: both lids close over ~2 frames and open over ~4, every `blink_gap` frames.
pub(crate) fn blinks(rig: &DragonRig, v: &mut [f64], frames: usize, st: &Style, rng: &mut ChaCha8Rng) {
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
pub(crate) fn eyes(rig: &DragonRig, v: &mut [f64], frames: usize, st: &Style, gaze: (f64, f64), rng: &mut ChaCha8Rng) {
    let c = rig.controls().len();
    let gaze = saccades(frames, st.saccade_gap, st.saccade_range, gaze, rng);
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
