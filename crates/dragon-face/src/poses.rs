//! Per-label pose libraries and timing styles: what an animator reaches for when keying
//! "happy", "roar", … A key pose sets the coarse shapes and the bones (head, jaw, ears,
//! brows, lids, tongue, nostrils); each part of the face takes only its own controls from
//! the poses it draws (see `parts`). Fine shapes and the lattice are touch-ups keyed on
//! their own (see `touchups`).

use crate::controls::{EAR_BONES, SIDES, TONGUE_BONES};
use crate::rig::DragonRig;
use rand::Rng;

/// Timing style of a label (frames at 24 fps).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Style {
    pub move_frames: (f64, f64),
    pub hold_frames: (f64, f64),
    pub anticipation: f64,
    pub overshoot: f64,
    pub blink_gap: (usize, usize),
    pub blink_close: f64,
    pub blink_open: f64,
    pub saccade_gap: (usize, usize),
    pub saccade_range: (f64, f64),
    pub breath: f64,
}

pub(crate) fn style(label: &str) -> Style {
    let s = |mv: (f64, f64),
             hold: (f64, f64),
             antic: f64,
             over: f64,
             blink: (usize, usize),
             sacc: (usize, usize),
             range: (f64, f64)| Style {
        move_frames: mv,
        hold_frames: hold,
        anticipation: antic,
        overshoot: over,
        blink_gap: blink,
        blink_close: 2.0,
        blink_open: 4.0,
        saccade_gap: sacc,
        saccade_range: range,
        breath: 1.0,
    };
    match label {
        "happy" => s((6.0, 12.0), (6.0, 20.0), 0.12, 0.10, (48, 120), (14, 40), (12.0, 8.0)),
        "grumpy" => s((8.0, 16.0), (10.0, 30.0), 0.08, 0.06, (60, 140), (20, 60), (10.0, 6.0)),
        "bored" => Style {
            blink_close: 3.0,
            blink_open: 6.0,
            breath: 1.6,
            ..s((12.0, 22.0), (16.0, 40.0), 0.05, 0.04, (48, 110), (30, 80), (8.0, 5.0))
        },
        "curious" => s((6.0, 12.0), (6.0, 18.0), 0.10, 0.12, (60, 144), (8, 24), (18.0, 10.0)),
        "neutral" => s((10.0, 18.0), (12.0, 36.0), 0.06, 0.05, (48, 130), (18, 50), (10.0, 6.0)),
        "roar" => Style { breath: 0.5, ..s((5.0, 10.0), (8.0, 20.0), 0.20, 0.15, (80, 144), (24, 60), (6.0, 4.0)) },
        "head_shake" => s((6.0, 12.0), (6.0, 14.0), 0.10, 0.10, (48, 100), (20, 48), (6.0, 4.0)),
        "surprise" => s((3.0, 6.0), (8.0, 24.0), 0.18, 0.20, (90, 144), (20, 48), (10.0, 6.0)),
        _ => panic!("unknown label {label}"),
    }
}

/// Share of a key pose's head attitude that the face rig's head bones play.
pub(crate) const HEAD_SCALE: f64 = 0.25;

/// A pose under construction: a full control vector with name-based setters.
pub(crate) struct Pose<'a> {
    pub v: Vec<f64>,
    rig: &'a DragonRig,
}

impl<'a> Pose<'a> {
    pub(crate) fn new(rig: &'a DragonRig) -> Pose<'a> {
        Pose { v: rig.default_pose(), rig }
    }
    fn i(&self, name: &str) -> usize {
        self.rig.control_index(name).unwrap_or_else(|| panic!("no control {name}"))
    }
    pub(crate) fn set(&mut self, name: &str, x: f64) {
        let i = self.i(name);
        self.v[i] = x;
    }
    pub(crate) fn add(&mut self, name: &str, x: f64) {
        let i = self.i(name);
        self.v[i] += x;
    }
    pub(crate) fn get(&self, name: &str) -> f64 {
        self.v[self.i(name)]
    }
    /// Set a `{s}`-templated control on the left and right side.
    fn both(&mut self, tmpl: &str, l: f64, r: f64) {
        self.set(&tmpl.replace("{s}", "L"), l);
        self.set(&tmpl.replace("{s}", "R"), r);
    }
    fn sym(&mut self, tmpl: &str, x: f64) {
        self.both(tmpl, x, x);
    }
    /// Head orientation, shared between the neck (30 %) and head (70 %) bones (degrees),
    /// played at [`HEAD_SCALE`] of the attitude named: a face performance moves the head
    /// a little, the body carries the big turns.
    fn head(&mut self, pitch: f64, yaw: f64, roll: f64) {
        for (ax, v) in [("rx", pitch), ("ry", yaw), ("rz", roll)] {
            self.set(&format!("neck_{ax}"), 0.3 * HEAD_SCALE * v);
            self.set(&format!("head_{ax}"), 0.7 * HEAD_SCALE * v);
        }
    }
    /// Head translation (cm) at [`HEAD_SCALE`], along `axis` (`"tx"`, `"ty"`, `"tz"`).
    fn head_shift(&mut self, axis: &str, cm: f64) {
        self.set(&format!("head_{axis}"), HEAD_SCALE * cm);
    }
    /// Ear pose: `up` raises (positive) or flattens (negative) the root, `curl` bends each
    /// further bone, `spread` swings the ears apart (degrees).
    fn ears(&mut self, up: f64, curl: f64, spread: f64, rng: &mut impl Rng) {
        for (s, _) in SIDES {
            for b in 0..EAR_BONES {
                let name = format!("ear_{s}_{:02}", b + 1);
                let bf = b as f64;
                self.set(&format!("{name}_rx"), up * (1.0 - 0.15 * bf) + curl * bf + rng.gen_range(-2.0..2.0));
                self.set(&format!("{name}_ry"), if b == 0 { spread } else { 0.0 } + rng.gen_range(-2.0..2.0));
                self.set(&format!("{name}_rz"), rng.gen_range(-3.0..3.0));
            }
        }
    }
    fn lids(&mut self, upper: f64, lower: f64, rng: &mut impl Rng) {
        for (s, _) in SIDES {
            self.set(&format!("eyelid_{s}_upper_rx"), upper + rng.gen_range(-2.0..2.0));
            self.set(&format!("eyelid_{s}_lower_rx"), lower + rng.gen_range(-1.5..1.5));
        }
    }
    fn brow_bones(&mut self, inner: f64, outer: f64, tilt: f64) {
        for (s, _) in SIDES {
            self.set(&format!("brow_{s}_inner_ty"), inner);
            self.set(&format!("brow_{s}_mid_ty"), 0.5 * (inner + outer));
            self.set(&format!("brow_{s}_outer_ty"), outer);
            self.set(&format!("brow_{s}_mid_rz"), tilt);
        }
    }
}

fn u(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    rng.gen_range(lo..hi)
}

fn sign(rng: &mut impl Rng) -> f64 {
    if rng.gen_bool(0.5) {
        1.0
    } else {
        -1.0
    }
}

/// Build one key pose for `label`. `first`: the opening key of a take (calmer for the
/// labels whose takes build up to a big action: roar winds up, surprise starts unaware).
pub(crate) fn key_pose(rig: &DragonRig, label: &str, first: bool, rng: &mut impl Rng) -> Vec<f64> {
    let mut p = Pose::new(rig);
    let r = rng;
    match label {
        "happy" => {
            let s = u(r, 0.55, 1.0);
            let asym = u(r, -0.12, 0.12);
            p.both("smile_{s}", s + asym, s - asym);
            p.sym("cheek_raise_{s}", 0.5 * s);
            p.sym("squint_{s}", 0.35 * s);
            p.sym("brow_up_{s}", u(r, 0.1, 0.4));
            p.sym("dimple_{s}", u(r, 0.0, 0.4) * s);
            p.sym("eye_{s}_dilate", u(r, 0.1, 0.4));
            p.ears(u(r, 10.0, 25.0), u(r, 0.0, 4.0), u(r, -5.0, 5.0), r);
            p.brow_bones(u(r, 0.2, 0.6), u(r, 0.1, 0.5), u(r, 0.0, 6.0));
            p.head(u(r, -8.0, 2.0), u(r, -10.0, 10.0), u(r, -8.0, 8.0));
            match r.gen_range(0..4) {
                0 => {
                    p.set("jaw_open", u(r, 4.0, 10.0));
                    p.set("jaw_open_shape", 0.2);
                    p.sym("lip_stretch_{s}", u(r, 0.1, 0.4));
                }
                1 => {
                    p.set("lip_press", u(r, 0.2, 0.4));
                    p.sym("mouth_wide_{s}", u(r, 0.1, 0.4));
                }
                2 => {
                    p.set("jaw_open", u(r, 14.0, 24.0));
                    p.set("jaw_open_shape", u(r, 0.3, 0.6));
                    p.head(u(r, -15.0, -6.0), u(r, -8.0, 8.0), u(r, -6.0, 6.0));
                    p.sym("cheek_raise_{s}", 0.8);
                    p.sym("squint_{s}", 0.6);
                    p.head_shift("ty", u(r, 0.5, 1.5));
                }
                _ => {
                    let side = sign(r);
                    p.head(u(r, 0.0, 6.0), u(r, -20.0, 20.0), side * u(r, 8.0, 15.0));
                    p.both("smile_{s}", 0.5, 0.45);
                    p.sym("brow_up_{s}", 0.4);
                }
            }
            p.lids(u(r, 0.0, 6.0), u(r, -6.0, 0.0), r);
        }
        "grumpy" => {
            p.sym("frown_{s}", u(r, 0.5, 0.9));
            p.sym("brow_down_{s}", u(r, 0.5, 0.9));
            p.sym("brow_squeeze_{s}", u(r, 0.4, 0.8));
            p.set("lip_press", u(r, 0.3, 0.7));
            p.set("chin_raise", u(r, 0.2, 0.6));
            p.sym("squint_{s}", u(r, 0.2, 0.5));
            p.sym("nose_wrinkle_{s}", u(r, 0.0, 0.3));
            p.set("jaw_clench", u(r, 0.3, 0.8));
            p.sym("eye_{s}_dilate", u(r, -0.4, -0.1));
            p.lids(u(r, 8.0, 18.0), u(r, -10.0, -3.0), r);
            p.ears(u(r, -35.0, -15.0), u(r, -4.0, 0.0), u(r, 0.0, 8.0), r);
            p.brow_bones(u(r, -1.0, -0.4), u(r, -0.2, 0.2), u(r, -8.0, -2.0));
            p.head(u(r, 5.0, 15.0), u(r, -8.0, 8.0), u(r, -5.0, 5.0));
            match r.gen_range(0..4) {
                0 => {
                    p.head(u(r, 5.0, 12.0), sign(r) * u(r, 12.0, 28.0), u(r, -5.0, 5.0));
                    let side = if r.gen_bool(0.5) { "mouth_left" } else { "mouth_right" };
                    p.set(side, u(r, 0.2, 0.5));
                }
                1 => {
                    p.sym("snarl_{s}", u(r, 0.2, 0.4));
                    p.add("head_rx", 4.0 * HEAD_SCALE);
                }
                2 => {
                    p.sym("cheek_puff_{s}", u(r, 0.4, 0.8));
                    p.set("lip_press", 0.8);
                }
                _ => {
                    p.both("brow_down_{s}", 0.9, 0.2);
                    p.set("brow_up_R", u(r, 0.2, 0.4));
                }
            }
        }
        "bored" => {
            p.lids(u(r, 18.0, 32.0), u(r, -4.0, 0.0), r);
            p.sym("frown_{s}", u(r, 0.0, 0.2));
            p.set("jaw_open", u(r, 0.0, 4.0));
            p.set("lip_roll_lower", u(r, 0.0, 0.2));
            p.sym("brow_up_{s}", u(r, 0.0, 0.15));
            p.sym("eye_{s}_dilate", u(r, -0.3, -0.1));
            p.ears(u(r, -30.0, -10.0), u(r, -6.0, -2.0), u(r, 5.0, 12.0), r);
            p.head(u(r, 5.0, 15.0), u(r, -10.0, 10.0), u(r, -18.0, 18.0));
            p.head_shift("ty", u(r, -1.5, -0.5));
            match r.gen_range(0..4) {
                0 => {}
                1 => {
                    p.sym("cheek_puff_{s}", 0.3);
                    p.set("lip_funnel", 0.3);
                    p.set("jaw_open", u(r, 3.0, 8.0));
                }
                2 => {
                    p.head(u(r, 6.0, 12.0), u(r, -6.0, 6.0), sign(r) * u(r, 15.0, 25.0));
                }
                _ => {
                    p.set("jaw_open", u(r, 20.0, 30.0));
                    p.set("jaw_open_shape", 0.5);
                    p.sym("squint_{s}", 0.5);
                    p.lids(u(r, 30.0, 40.0), -5.0, r);
                }
            }
        }
        "curious" => {
            let (hi, lo) = (u(r, 0.4, 0.9), u(r, 0.1, 0.6));
            if r.gen_bool(0.5) {
                p.both("brow_up_{s}", hi, lo);
            } else {
                p.both("brow_up_{s}", lo, hi);
            }
            p.sym("eye_wide_{s}", u(r, 0.2, 0.5));
            p.sym("eye_{s}_dilate", u(r, 0.2, 0.5));
            p.set("lip_pucker", u(r, 0.0, 0.3));
            p.set("jaw_open", u(r, 0.0, 6.0));
            p.lids(u(r, -10.0, 0.0), u(r, 0.0, 4.0), r);
            p.ears(u(r, 15.0, 35.0), u(r, 0.0, 5.0), u(r, -10.0, 0.0), r);
            p.brow_bones(u(r, 0.3, 1.0), u(r, 0.2, 0.8), u(r, 0.0, 8.0));
            p.head(u(r, -5.0, 5.0), u(r, -12.0, 12.0), sign(r) * u(r, 10.0, 22.0));
            p.head_shift("tz", u(r, 1.0, 2.5));
            match r.gen_range(0..3) {
                0 => {}
                1 => {
                    p.set("squint_L", 0.4);
                    p.head_shift("tz", u(r, 2.0, 3.0));
                }
                _ => {
                    p.sym("nose_wrinkle_{s}", 0.4);
                    p.set("snout_scrunch", 0.3);
                }
            }
        }
        "neutral" => {
            p.sym("smile_{s}", u(r, 0.0, 0.15));
            p.sym("brow_up_{s}", u(r, 0.0, 0.15));
            p.lids(u(r, 0.0, 8.0), u(r, -3.0, 0.0), r);
            p.ears(u(r, -5.0, 10.0), u(r, -2.0, 2.0), u(r, -3.0, 3.0), r);
            p.head(u(r, -5.0, 5.0), u(r, -6.0, 6.0), u(r, -4.0, 4.0));
            match r.gen_range(0..4) {
                0 => {}
                1 => p.head(u(r, -4.0, 4.0), u(r, -25.0, 25.0), u(r, -4.0, 4.0)),
                2 => p.sym("smile_{s}", u(r, 0.2, 0.3)),
                _ => p.ears(u(r, 12.0, 20.0), 2.0, 0.0, r),
            }
        }
        "roar" => {
            let v = if first { 1 } else { [0, 0, 1, 2][r.gen_range(0..4)] };
            match v {
                0 => {
                    p.set("jaw_open", u(r, 32.0, 42.0));
                    p.set("jaw_open_shape", u(r, 0.8, 1.0));
                    p.sym("snarl_{s}", u(r, 0.7, 1.0));
                    p.sym("nose_wrinkle_{s}", u(r, 0.6, 1.0));
                    p.sym("upper_lip_raise_{s}", u(r, 0.6, 0.9));
                    p.sym("lower_lip_depress_{s}", u(r, 0.5, 0.9));
                    p.sym("brow_down_{s}", u(r, 0.6, 1.0));
                    p.sym("squint_{s}", 0.6);
                    p.sym("mouth_wide_{s}", 0.5);
                    p.sym("lip_stretch_{s}", 0.5);
                    p.sym("eye_{s}_dilate", -0.5);
                    p.ears(u(r, -55.0, -35.0), u(r, -6.0, -2.0), u(r, 5.0, 15.0), r);
                    p.head(u(r, -20.0, -10.0), u(r, -10.0, 10.0), u(r, -6.0, 6.0));
                    p.head_shift("tz", u(r, 1.0, 2.5));
                    p.brow_bones(-1.2, -0.3, -10.0);
                    p.lids(10.0, -8.0, r);
                }
                1 => {
                    p.head(u(r, 8.0, 18.0), u(r, -6.0, 6.0), u(r, -4.0, 4.0));
                    p.head_shift("tz", u(r, -2.0, -0.5));
                    p.set("jaw_open", u(r, 4.0, 10.0));
                    p.sym("brow_down_{s}", 0.5);
                    p.sym("snarl_{s}", 0.3);
                    p.sym("cheek_puff_{s}", 0.3);
                    p.ears(-20.0, -2.0, 5.0, r);
                    p.lids(6.0, -4.0, r);
                }
                _ => {
                    p.set("jaw_open", u(r, 8.0, 16.0));
                    p.sym("snarl_{s}", 0.9);
                    p.sym("nose_wrinkle_{s}", 0.8);
                    p.sym("brow_down_{s}", 0.8);
                    p.head(u(r, 0.0, 8.0), u(r, -8.0, 8.0), u(r, -4.0, 4.0));
                    p.ears(-30.0, -3.0, 8.0, r);
                    p.brow_bones(-0.8, 0.0, -6.0);
                }
            }
            p.set("jaw_clench", if v == 0 { 0.0 } else { u(r, 0.4, 0.9) });
        }
        "head_shake" => {
            p.sym("frown_{s}", u(r, 0.2, 0.6));
            p.sym("brow_down_{s}", u(r, 0.3, 0.7));
            p.sym("squint_{s}", u(r, 0.2, 0.5));
            p.set("lip_press", u(r, 0.3, 0.6));
            p.lids(u(r, 10.0, 25.0), -3.0, r);
            p.ears(u(r, -20.0, -5.0), u(r, -2.0, 2.0), u(r, 0.0, 6.0), r);
            p.head(u(r, 2.0, 10.0), u(r, -5.0, 5.0), u(r, -4.0, 4.0));
            match r.gen_range(0..3) {
                0 => {}
                1 => p.lids(u(r, 30.0, 40.0), -6.0, r),
                _ => {
                    p.sym("brow_up_{s}", 0.5);
                    p.sym("brow_down_{s}", 0.0);
                    p.sym("mouth_wide_{s}", 0.3);
                }
            }
        }
        "surprise" => {
            let v = if first && r.gen_bool(0.8) { 2 } else { [0, 0, 1, 2][r.gen_range(0..4)] };
            match v {
                0 | 1 => {
                    p.sym("brow_up_{s}", u(r, 0.8, 1.0));
                    p.sym("eye_wide_{s}", u(r, 0.7, 1.0));
                    p.set("forehead_raise", u(r, 0.5, 0.9));
                    p.lids(u(r, -25.0, -12.0), u(r, 5.0, 12.0), r);
                    p.set("jaw_open", if v == 0 { u(r, 12.0, 24.0) } else { u(r, 25.0, 32.0) });
                    p.set("jaw_open_shape", u(r, 0.3, 0.6));
                    p.set("lip_funnel", if v == 0 { u(r, 0.2, 0.5) } else { 0.6 });
                    p.ears(u(r, 30.0, 50.0), u(r, 2.0, 6.0), u(r, -8.0, 0.0), r);
                    p.head(u(r, -15.0, -6.0), u(r, -8.0, 8.0), u(r, -5.0, 5.0));
                    p.head_shift("tz", u(r, -2.5, -1.0));
                    p.sym("eye_{s}_dilate", u(r, 0.6, 0.9));
                    p.brow_bones(u(r, 0.6, 1.1), u(r, 0.4, 0.9), 6.0);
                    if v == 1 {
                        p.sym("cheek_suck_{s}", 0.2);
                    }
                }
                _ => {
                    p.sym("brow_up_{s}", u(r, 0.0, 0.5));
                    p.set("jaw_open", u(r, 0.0, 5.0));
                    p.sym("smile_{s}", u(r, 0.0, 0.3));
                    p.ears(u(r, 0.0, 12.0), 0.0, 0.0, r);
                    p.head(u(r, -3.0, 5.0), u(r, -10.0, 10.0), u(r, -4.0, 4.0));
                    p.lids(u(r, 0.0, 6.0), -2.0, r);
                }
            }
        }
        _ => panic!("unknown label {label}"),
    }
    extras(&mut p, label, r);
    tongue_and_nostrils(&mut p, r);
    p.v
}

/// Small secondary controls an animator touches on most keys, plus occasional label-typical
/// details (a swallow, rolled lips, jowls, a narrowed mouth).
fn extras(p: &mut Pose, label: &str, r: &mut impl Rng) {
    p.head_shift("tx", u(r, -0.8, 0.8));
    p.set("jaw_side", u(r, -3.0, 3.0));
    p.set("jaw_twist", u(r, -2.0, 2.0));
    p.set("jaw_fwd", if label == "roar" { u(r, 0.3, 1.0) } else { u(r, -0.3, 0.3) });
    for (s, _) in SIDES {
        let tilt = p.get(&format!("brow_{s}_mid_rz"));
        p.set(&format!("brow_{s}_inner_rz"), 0.6 * tilt + u(r, -2.0, 2.0));
        p.set(&format!("brow_{s}_outer_rz"), 1.2 * tilt + u(r, -2.0, 2.0));
        p.set(&format!("eyelid_{s}_upper_rz"), u(r, -3.0, 3.0));
        p.set(&format!("eyelid_{s}_lower_rz"), u(r, -3.0, 3.0));
    }
    let shift = if r.gen_bool(0.5) { "mouth_left" } else { "mouth_right" };
    let mut maybe = |name: &str, prob: f64, lo: f64, hi: f64| {
        if r.gen_bool(prob) {
            let x = u(r, lo, hi);
            if name.contains("{s}") {
                p.sym(name, x);
            } else {
                p.set(name, x);
            }
        }
    };
    maybe(shift, 0.3, 0.0, 0.25);
    match label {
        "grumpy" => {
            maybe("lip_roll_upper", 0.5, 0.2, 0.6);
            maybe("jowl_{s}", 0.5, 0.2, 0.6);
        }
        "bored" => {
            maybe("jowl_{s}", 0.4, 0.2, 0.5);
            maybe("throat_swallow", 0.25, 0.4, 1.0);
        }
        "curious" | "surprise" => maybe("mouth_narrow_{s}", 0.4, 0.2, 0.6),
        "neutral" => maybe("throat_swallow", 0.15, 0.4, 1.0),
        "head_shake" => maybe("lip_roll_upper", 0.3, 0.1, 0.4),
        _ => {}
    }
}

/// The tongue and nostril bones: small swings (±3–6°) keyed on most poses, and a handful
/// of controls ([`WIDE_SWINGS`]) that animators swing freely over ±30° although they barely
/// move the mesh — the large-variance, little-effect controls that scaling exists for.
fn tongue_and_nostrils(p: &mut Pose, r: &mut impl Rng) {
    for i in 1..=TONGUE_BONES {
        for ax in ["rx", "ry", "rz"] {
            p.set(&format!("tongue_{i:02}_{ax}"), u(r, -6.0, 6.0));
        }
    }
    for (s, _) in SIDES {
        for i in 1..=2 {
            for ax in ["rx", "ry", "rz"] {
                p.set(&format!("nostril_{s}_{i:02}_{ax}"), u(r, -3.0, 3.0));
            }
        }
    }
    for name in WIDE_SWINGS {
        p.set(name, u(r, -30.0, 30.0));
    }
}

/// The handful of tiny-effect controls keyed over ±30°.
pub(crate) const WIDE_SWINGS: [&str; 6] =
    ["tongue_02_rx", "tongue_03_ry", "tongue_01_rz", "nostril_L_01_rx", "nostril_R_02_rz", "nostril_R_01_ry"];
