//! Blendshape layers: coarse shapes, fine shapes, tweak offsets and combination correctives.
//!
//! Every shape is a sparse vertex-delta field `D` (cm per unit control) built from smooth
//! compact bumps: `δ_v = Σ_b a_b · (1 − (|v − c_b| / r_b)²)² · dir_b(v) · mask_b(v)`.
//! A shape layer adds `w · D` for its control value `w` (sliders: 0..1 or −1..1; tweak
//! offsets: the value is in cm, the field has unit amplitude). A corrective adds
//! `Π_j clamp((p_j − lo_j)/(hi_j − lo_j), 0, 1) · D` for its driver controls `p_j`.
//! Deltas are stored only on their support (|δ| > 1e-4 cm) and zero weights are skipped.

use crate::controls::{FINE_FAMILIES, SIDES, TWEAK_REGIONS};
use crate::math::*;
use crate::mesh::{ring_theta, Mesh, Part, MOUTH_RING, RINGS};
use rand::Rng;
use std::f64::consts::PI;

/// A sparse vertex-delta field (cm).
#[derive(Clone, Debug)]
pub(crate) struct Sparse {
    pub idx: Vec<u32>,
    pub delta: Vec<V3>,
}

impl Sparse {
    /// `out[3v..3v+3] += w · δ_v` over the support.
    #[inline]
    pub(crate) fn add_scaled(&self, w: f64, out: &mut [f64]) {
        for (&v, d) in self.idx.iter().zip(&self.delta) {
            let o = &mut out[3 * v as usize..3 * v as usize + 3];
            o[0] += w * d[0];
            o[1] += w * d[1];
            o[2] += w * d[2];
        }
    }
}

/// A blendshape driven linearly by one control.
#[derive(Clone, Debug)]
pub(crate) struct Shape {
    pub control: usize,
    pub field: Sparse,
}

/// A corrective shape: fires on the product of normalised driver controls.
#[derive(Clone, Debug)]
pub(crate) struct Corrective {
    /// (control index, value giving weight 0, value giving weight 1).
    pub drivers: Vec<(usize, f64, f64)>,
    pub field: Sparse,
}

impl Corrective {
    pub(crate) fn weight(&self, controls: &[f64]) -> f64 {
        let mut w = 1.0;
        for &(c, lo, hi) in &self.drivers {
            w *= ((controls[c] - lo) / (hi - lo)).clamp(0.0, 1.0);
            if w == 0.0 {
                break;
            }
        }
        w
    }
}

#[derive(Clone, Copy)]
enum Dir {
    Fixed(V3),
    /// Along the rest vertex normal (negative amplitude: inwards).
    Normal,
    /// Along ±x away from the midline (negative amplitude: towards it).
    Lateral,
}

#[derive(Clone, Copy)]
enum Mask {
    Head,
    /// Above the mouth slit (upper lip side); continuous skin beyond the mouth corners.
    Above,
    Below,
    Eye(usize),
}

#[derive(Clone, Copy)]
struct Bump {
    c: V3,
    r: f64,
    a: f64,
    dir: Dir,
    mask: Mask,
}

fn bump(c: V3, r: f64, a: f64, dir: Dir, mask: Mask) -> Bump {
    Bump { c, r, a, dir, mask }
}

fn fixed(v: V3) -> Dir {
    Dir::Fixed(normalize(v))
}

fn mask_weight(mesh: &Mesh, mask: Mask, v: usize) -> f64 {
    let mouth_side = |above: bool| {
        let ring = mesh.ring[v];
        let on_side = if above { ring <= MOUTH_RING as i32 } else { ring > MOUTH_RING as i32 };
        if on_side {
            1.0
        } else {
            let a = mesh.params.mouth_phi;
            smoothstep(a, a + 0.3, mesh.phi[v].abs())
        }
    };
    match (mask, mesh.part[v]) {
        (Mask::Head, Part::Head) => 1.0,
        (Mask::Above, Part::Head) => mouth_side(true),
        (Mask::Below, Part::Head) => mouth_side(false),
        (Mask::Eye(s), Part::Eye(t)) if s == t => 1.0,
        _ => 0.0,
    }
}

/// Build the sparse field of a list of bumps over the rest mesh.
fn field(mesh: &Mesh, bumps: &[Bump]) -> Sparse {
    let mut idx = Vec::new();
    let mut delta = Vec::new();
    for v in 0..mesh.pos.len() {
        let p = mesh.pos[v];
        let mut d = [0.0; 3];
        for b in bumps {
            let f = falloff(dist(p, b.c), b.r);
            if f == 0.0 {
                continue;
            }
            let m = mask_weight(mesh, b.mask, v);
            if m == 0.0 {
                continue;
            }
            let dir = match b.dir {
                Dir::Fixed(u) => u,
                Dir::Normal => mesh.normals[v],
                Dir::Lateral => [p[0].signum() * smoothstep(0.0, 1.0, p[0].abs()), 0.0, 0.0],
            };
            d = add(d, scale(dir, b.a * f * m));
        }
        if norm(d) > 1e-4 {
            idx.push(v as u32);
            delta.push(d);
        }
    }
    Sparse { idx, delta }
}

/// Facial landmarks on the rest mesh.
struct Landmarks {
    dtheta: f64,
    theta_m: f64,
    mouth_phi: f64,
}

impl Landmarks {
    fn new(mesh: &Mesh) -> Landmarks {
        Landmarks {
            dtheta: PI / (RINGS as f64 + 1.0),
            theta_m: ring_theta(MOUTH_RING),
            mouth_phi: mesh.params.mouth_phi,
        }
    }
    fn surf(&self, mesh: &Mesh, dth: f64, phi: f64) -> V3 {
        mesh.params.surface(self.theta_m + dth * self.dtheta, phi)
    }
    fn corner(&self, mesh: &Mesh, sx: f64) -> V3 {
        self.surf(mesh, 0.5, sx * self.mouth_phi)
    }
    /// Point above the eye on the brow: `u = −1` inner, `+1` outer.
    fn brow(&self, mesh: &Mesh, side: usize, u: f64) -> V3 {
        let e = &mesh.eyes[side];
        let sx = SIDES[side].1;
        let t = add(add(e.centre, scale(e.up, e.radius + 2.2)), [sx * u * 2.4, -0.3 * u * u, -u * 0.8]);
        mesh.pos[mesh.nearest_head_vertex(t)]
    }
    /// Point on the lid rim: `h ∈ [−1, 1]` across the eye, upper or lower lid.
    fn lid(&self, mesh: &Mesh, side: usize, h: f64, upper: bool) -> V3 {
        let e = &mesh.eyes[side];
        let vy = if upper { 0.75 } else { -0.65 } * (1.0 - 0.4 * h * h);
        let d = normalize(add(add(e.axis, scale(e.side, (h * 0.8).tan())), scale(e.up, vy)));
        add(e.centre, scale(d, e.radius + 0.15))
    }
    fn nostril(&self, mesh: &Mesh, sx: f64) -> V3 {
        mesh.params.surface(0.42 * PI, sx * 0.12)
    }
}

/// Coarse blendshape recipes (also the brows/jaw/eyes sliders), by control name.
fn coarse_recipes(mesh: &Mesh, lm: &Landmarks) -> Vec<(String, Vec<Bump>)> {
    use Mask::*;
    let mut out: Vec<(String, Vec<Bump>)> = Vec::new();
    let mut put = |name: String, b: Vec<Bump>| out.push((name, b));
    let upper_mid = lm.surf(mesh, 0.0, 0.0);
    let lower_mid = lm.surf(mesh, 0.5, 0.0);
    let chin = lm.surf(mesh, 6.0, 0.0);
    for (side, &(s, sx)) in SIDES.iter().enumerate() {
        let corner = lm.corner(mesh, sx);
        let cheek = lm.surf(mesh, -6.0, sx * (lm.mouth_phi + 0.35));
        let eye = &mesh.eyes[side];
        let upper_lid = add(eye.centre, scale(normalize(add(eye.axis, eye.up)), eye.radius + 0.3));
        let lower_lid = add(eye.centre, scale(normalize(sub(eye.axis, scale(eye.up, 0.8))), eye.radius + 0.3));
        let canine = lm.surf(mesh, -2.0, sx * 0.35);
        put(
            format!("smile_{s}"),
            vec![
                bump(corner, 4.5, 1.6, fixed([sx * 0.35, 0.8, -0.45]), Head),
                bump(cheek, 4.0, 0.5, Dir::Normal, Head),
            ],
        );
        put(format!("frown_{s}"), vec![bump(corner, 4.5, 1.2, fixed([sx * 0.1, -1.0, 0.0]), Head)]);
        put(format!("snarl_{s}"), vec![bump(canine, 3.5, 1.4, fixed([0.0, 1.0, 0.2]), Above)]);
        put(format!("cheek_puff_{s}"), vec![bump(cheek, 4.5, 1.5, Dir::Normal, Head)]);
        put(
            format!("cheek_raise_{s}"),
            vec![bump(lm.surf(mesh, -9.0, sx * (lm.mouth_phi + 0.3)), 3.5, 1.0, fixed([0.0, 1.0, 0.3]), Head)],
        );
        put(format!("cheek_suck_{s}"), vec![bump(cheek, 3.5, -0.9, Dir::Normal, Head)]);
        put(format!("mouth_wide_{s}"), vec![bump(corner, 4.0, 1.2, fixed([sx, 0.0, -0.2]), Head)]);
        put(format!("mouth_narrow_{s}"), vec![bump(corner, 4.0, 1.0, fixed([-sx, 0.0, 0.3]), Head)]);
        put(
            format!("nose_wrinkle_{s}"),
            vec![
                bump(mesh.params.surface(0.40 * PI, sx * 0.25), 3.0, 0.8, fixed([0.0, 1.0, -0.3]), Head),
                bump(mesh.params.surface(0.40 * PI, sx * 0.25), 2.0, 0.3, Dir::Normal, Head),
            ],
        );
        put(
            format!("upper_lip_raise_{s}"),
            vec![bump(lm.surf(mesh, -1.0, sx * 0.25), 3.0, 1.0, fixed([0.0, 1.0, 0.0]), Above)],
        );
        put(
            format!("lower_lip_depress_{s}"),
            vec![bump(lm.surf(mesh, 2.0, sx * 0.25), 3.0, 1.0, fixed([0.0, -1.0, 0.0]), Below)],
        );
        put(format!("squint_{s}"), vec![bump(lower_lid, 2.5, 0.6, fixed([0.0, 1.0, 0.0]), Head)]);
        put(format!("eye_wide_{s}"), vec![bump(upper_lid, 2.5, 0.6, fixed([0.0, 1.0, 0.0]), Head)]);
        put(
            format!("dimple_{s}"),
            vec![bump(lm.surf(mesh, 1.0, sx * (lm.mouth_phi + 0.15)), 1.8, -0.5, Dir::Normal, Head)],
        );
        put(format!("lip_stretch_{s}"), vec![bump(corner, 4.0, 1.0, fixed([sx, -0.3, -0.3]), Head)]);
        put(
            format!("jowl_{s}"),
            vec![
                bump(lm.surf(mesh, 10.0, sx * 1.0), 5.0, 0.6, fixed([0.0, -1.0, 0.0]), Head),
                bump(lm.surf(mesh, 10.0, sx * 1.0), 5.0, 0.4, Dir::Normal, Head),
            ],
        );
        put(format!("brow_up_{s}"), vec![bump(lm.brow(mesh, side, 0.0), 5.0, 1.0, fixed([0.0, 1.0, 0.0]), Head)]);
        put(format!("brow_down_{s}"), vec![bump(lm.brow(mesh, side, 0.0), 5.0, 0.9, fixed([0.0, -1.0, 0.3]), Head)]);
        put(
            format!("brow_squeeze_{s}"),
            vec![bump(lm.brow(mesh, side, -1.0), 3.5, 0.8, fixed([-sx, -0.2, 0.0]), Head)],
        );
        put(
            format!("eye_{s}_dilate"),
            vec![bump(add(eye.centre, [0.0, 0.0, eye.radius]), 1.3, 0.1, Dir::Normal, Eye(side))],
        );
    }
    put("jaw_open_shape".into(), vec![bump(chin, 9.0, 1.8, fixed([0.0, -1.0, -0.25]), Below)]);
    put(
        "lip_pucker".into(),
        vec![
            bump(upper_mid, 5.0, 1.2, fixed([0.0, 0.0, 1.0]), Above),
            bump(lower_mid, 5.0, 1.2, fixed([0.0, 0.0, 1.0]), Below),
            bump(upper_mid, 6.0, -0.8, Dir::Lateral, Head),
        ],
    );
    put(
        "lip_funnel".into(),
        vec![
            bump(upper_mid, 4.5, 1.0, fixed([0.0, 0.3, 1.0]), Above),
            bump(lower_mid, 4.5, 1.0, fixed([0.0, -0.3, 1.0]), Below),
        ],
    );
    put(
        "lip_press".into(),
        vec![
            bump(upper_mid, 5.0, 0.4, fixed([0.0, -1.0, 0.0]), Above),
            bump(lower_mid, 5.0, 0.4, fixed([0.0, 1.0, 0.0]), Below),
        ],
    );
    put("lip_roll_upper".into(), vec![bump(upper_mid, 4.5, -0.5, Dir::Normal, Above)]);
    put("lip_roll_lower".into(), vec![bump(lower_mid, 4.5, -0.5, Dir::Normal, Below)]);
    put("mouth_left".into(), vec![bump(upper_mid, 7.0, 1.2, fixed([1.0, 0.0, 0.0]), Head)]);
    put("mouth_right".into(), vec![bump(upper_mid, 7.0, 1.2, fixed([-1.0, 0.0, 0.0]), Head)]);
    put("chin_raise".into(), vec![bump(chin, 4.0, 0.8, fixed([0.0, 0.6, 0.8]), Below)]);
    put(
        "throat_swallow".into(),
        vec![bump(mesh.params.surface(0.88 * PI, PI), 5.0, 0.8, fixed([0.0, 1.0, 0.0]), Head)],
    );
    put(
        "snout_scrunch".into(),
        vec![
            bump(mesh.params.surface(0.5 * PI, 0.0), 5.0, 1.0, fixed([0.0, 0.0, -1.0]), Head),
            bump(mesh.params.surface(0.42 * PI, 0.0), 4.0, 0.4, fixed([0.0, 1.0, 0.0]), Head),
        ],
    );
    put(
        "forehead_raise".into(),
        vec![bump(mesh.params.surface(0.15 * PI, 0.0), 7.0, 0.8, fixed([0.0, 1.0, 0.0]), Head)],
    );
    let mut clench = Vec::new();
    for (_, sx) in SIDES {
        clench.push(bump(lm.surf(mesh, -2.0, sx * 1.5), 3.5, 0.5, Dir::Normal, Head));
    }
    put("jaw_clench".into(), clench);
    out
}

/// Centre, radius and mask of fine-family segment `seg` on side `side`.
fn fine_site(mesh: &Mesh, lm: &Landmarks, prefix: &str, side: usize, seg: usize, count: usize) -> (V3, f64, Mask) {
    let sx = SIDES[side].1;
    let u = 2.0 * (seg as f64 + 0.5) / count as f64 - 1.0; // −1..1 across the feature
    let half = seg % (count / 2).max(1); // index within a row of a 2-row family
    let row = if count > 1 { seg / (count / 2).max(1) } else { 0 };
    let urow = 2.0 * (half as f64 + 0.5) / (count / 2).max(1) as f64 - 1.0;
    match prefix {
        "lip_upper" => (lm.surf(mesh, 0.0, u * lm.mouth_phi), 1.6, Mask::Above),
        "lip_lower" => (lm.surf(mesh, 0.5, u * lm.mouth_phi), 1.6, Mask::Below),
        "brow_seg" => (lm.brow(mesh, side, u), 1.8, Mask::Head),
        "lid_upper" => (lm.lid(mesh, side, u, true), 1.0, Mask::Head),
        "lid_lower" => (lm.lid(mesh, side, u, false), 1.0, Mask::Head),
        "cheek" => {
            let phi = sx * (lm.mouth_phi + 0.1 + 0.25 * (urow + 1.0));
            (lm.surf(mesh, [-7.0, -3.0][row], phi), 2.2, Mask::Head)
        }
        "snout_ridge" => (mesh.params.surface((0.22 + 0.22 * (u + 1.0) / 2.0) * PI, 0.0), 1.8, Mask::Head),
        "nostril_seg" => {
            let a = seg as f64 * PI / 2.0;
            let c = lm.nostril(mesh, sx);
            (add(c, [0.6 * a.cos(), 0.6 * a.sin(), 0.0]), 1.0, Mask::Head)
        }
        "chin" => (lm.surf(mesh, [4.0, 7.0][row], 0.5 * urow), 2.0, Mask::Below),
        "mouth_corner" => (lm.corner(mesh, sx), 1.5, Mask::Head),
        "jawline" => (lm.surf(mesh, 10.0, sx * (0.6 + 0.2 * seg as f64)), 2.5, Mask::Head),
        "forehead" => (mesh.params.surface([0.12, 0.22][row] * PI, 0.9 * urow), 2.5, Mask::Head),
        _ => unreachable!("unknown fine family {prefix}"),
    }
}

fn fine_dir(dir: &str) -> (Dir, f64) {
    match dir {
        "up" => (fixed([0.0, 1.0, 0.0]), 1.0),
        "down" => (fixed([0.0, -1.0, 0.0]), 1.0),
        "out" => (Dir::Normal, 1.0),
        "in" => (Dir::Normal, -1.0),
        "flare" => (Dir::Lateral, 1.0),
        "narrow" => (Dir::Lateral, -1.0),
        _ => unreachable!("unknown fine direction {dir}"),
    }
}

/// All blendshapes (coarse, fine, tweak) and correctives, resolved to control indices.
pub(crate) fn build(
    mesh: &Mesh,
    index: &dyn Fn(&str) -> usize,
    rng: &mut impl Rng,
) -> (Vec<Shape>, Vec<Shape>, Vec<Corrective>) {
    let lm = Landmarks::new(mesh);
    let mut coarse = Vec::new();
    for (name, mut bumps) in coarse_recipes(mesh, &lm) {
        let j = rng.gen_range(0.9..1.1);
        bumps.iter_mut().for_each(|b| b.a *= j);
        coarse.push(Shape { control: index(&name), field: field(mesh, &bumps) });
    }
    let mut fine = Vec::new();
    for fam in &FINE_FAMILIES {
        for (side, &(s, _)) in fam.sides().iter().enumerate() {
            for seg in 0..fam.count {
                let (c, r, mask) = fine_site(mesh, &lm, fam.prefix, side, seg, fam.count);
                let r = r * rng.gen_range(0.85..1.15);
                for d in fam.dirs {
                    let (dir, sign) = fine_dir(d);
                    let a = sign * 0.45 * rng.gen_range(0.8..1.2);
                    let b = bump(c, r, a, dir, mask);
                    fine.push(Shape { control: index(&fam.name(s, seg, d)), field: field(mesh, &[b]) });
                }
            }
        }
    }
    // Tweak offsets: unit-amplitude translations of small regions (value in cm).
    for region in TWEAK_REGIONS {
        let c = match region {
            "brow_L" => lm.brow(mesh, 0, 0.0),
            "brow_R" => lm.brow(mesh, 1, 0.0),
            "cheek_L" => lm.surf(mesh, -6.0, lm.mouth_phi + 0.35),
            "cheek_R" => lm.surf(mesh, -6.0, -(lm.mouth_phi + 0.35)),
            "snout" => mesh.params.surface(0.45 * PI, 0.0),
            "chin" => lm.surf(mesh, 6.0, 0.0),
            "mouth_corner_L" => lm.corner(mesh, 1.0),
            _ => lm.corner(mesh, -1.0),
        };
        for (axis, ax) in ["tx", "ty", "tz"].iter().enumerate() {
            let mut u = [0.0; 3];
            u[axis] = 1.0;
            let b = bump(c, 3.0, 1.0, Dir::Fixed(u), Mask::Head);
            fine.push(Shape { control: index(&format!("tweak_{region}_{ax}")), field: field(mesh, &[b]) });
        }
    }
    let correctives = correctives(mesh, &lm, index);
    (coarse, fine, correctives)
}

fn correctives(mesh: &Mesh, lm: &Landmarks, index: &dyn Fn(&str) -> usize) -> Vec<Corrective> {
    let jaw = (index("jaw_open"), 0.0, 35.0);
    let sl = |n: &str| (index(n), 0.0, 1.0);
    let mut out = Vec::new();
    let mut put = |drivers: Vec<(usize, f64, f64)>, bumps: Vec<Bump>| {
        out.push(Corrective { drivers, field: field(mesh, &bumps) });
    };
    put(vec![jaw, sl("lip_pucker")], vec![bump(lm.surf(mesh, 0.0, 0.0), 4.0, 0.5, fixed([0.0, 0.0, 1.0]), Mask::Head)]);
    for (side, &(s, sx)) in SIDES.iter().enumerate() {
        let corner = lm.corner(mesh, sx);
        put(
            vec![jaw, sl(&format!("smile_{s}"))],
            vec![bump(corner, 3.5, 0.6, fixed([sx * 0.3, 0.4, 0.2]), Mask::Head)],
        );
        put(vec![jaw, sl(&format!("frown_{s}"))], vec![bump(corner, 3.5, 0.4, fixed([0.0, 0.4, 0.1]), Mask::Head)]);
        put(
            vec![sl(&format!("brow_up_{s}")), sl(&format!("brow_down_{s}"))],
            vec![bump(lm.brow(mesh, side, 0.0), 3.0, 0.5, Dir::Normal, Mask::Head)],
        );
        put(
            vec![sl(&format!("smile_{s}")), sl(&format!("squint_{s}"))],
            vec![bump(lm.surf(mesh, -9.0, sx * (lm.mouth_phi + 0.3)), 3.0, 0.4, fixed([0.0, 1.0, 0.2]), Mask::Head)],
        );
        put(
            vec![sl(&format!("snarl_{s}")), sl(&format!("nose_wrinkle_{s}"))],
            vec![bump(mesh.params.surface(0.44 * PI, sx * 0.3), 2.5, 0.4, fixed([0.0, 1.0, 0.0]), Mask::Head)],
        );
    }
    out
}
