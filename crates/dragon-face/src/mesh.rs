//! The rest mesh: a stylised creature head (deformed UV sphere with a snout, a mouth slit and
//! sockets), two leaf-shaped ears, two eyeballs and a small tongue hidden in the mouth.
//!
//! Frame and units: centimetres; +y up, +z forward (the snout), +x the character's left (`L`).
//! The head has a mouth slit (missing triangles between the lip rings); the eyeballs poke
//! through the skin, whose rim hugs them. Head surface point for polar angle θ (from +y) and azimuth φ (from +z towards +x), with
//! `d = (sin θ sin φ, cos θ, sin θ cos φ)` and snout factor `s = smoothstep(0.2, 1, d_z)`:
//! `x = rx·d_x·(1 − narrow·s)`, `y = ry·d_y·(0.9 if d_y<0) − drop·s`,
//! `z = rz·d_z·(1.08 if d_z<0) + snout·s^1.5` — about 34 cm long, 24 wide, 21 tall.

use crate::math::*;
use rand::Rng;
use std::f64::consts::PI;
use std::ops::Range;

/// Number of latitude rings and longitude segments of the head sphere (3040 head vertices).
pub(crate) const RINGS: usize = 49;
pub(crate) const SEGS: usize = 62;
/// Ring index of the upper lip; ring `MOUTH_RING + 1` is the lower lip.
pub(crate) const MOUTH_RING: usize = 27;

const EAR_RINGS: usize = 12;
const EAR_RING_VERTS: usize = 8;
const EYE_RINGS: usize = 10;
const EYE_SEGS: usize = 12;
const TONGUE_RINGS: usize = 4;
const TONGUE_SEGS: usize = 6;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Part {
    Head,
    Ear(usize),
    Eye(usize),
    Tongue,
}

/// Seed-jittered proportions of the head.
#[derive(Clone, Debug)]
pub(crate) struct HeadParams {
    pub rx: f64,
    pub ry: f64,
    pub rz: f64,
    pub snout: f64,
    pub drop: f64,
    pub narrow: f64,
    pub ear_len: f64,
    pub eye_r: f64,
    /// Half-width of the mouth slit in azimuth (radians).
    pub mouth_phi: f64,
}

/// An eye: eyeball centre and radius plus the frame of the eye opening in the head skin.
#[derive(Clone, Debug)]
pub(crate) struct EyeGeom {
    pub centre: V3,
    pub radius: f64,
    /// Opening axis (outward), its up and side directions.
    pub axis: V3,
    pub up: V3,
    pub side: V3,
}

#[derive(Clone, Debug)]
pub(crate) struct EarGeom {
    pub root: V3,
    pub dir: V3,
    pub length: f64,
}

#[derive(Clone, Debug)]
pub(crate) struct Mesh {
    pub params: HeadParams,
    pub pos: Vec<V3>,
    pub tris: Vec<[u32; 3]>,
    pub normals: Vec<V3>,
    pub part: Vec<Part>,
    /// Named vertex ranges: head, ear_L, ear_R, eye_L, eye_R, tongue.
    pub ranges: Vec<(&'static str, Range<usize>)>,
    /// Head vertices: latitude ring (−1 top pole, RINGS bottom pole); `i32::MIN` elsewhere.
    pub ring: Vec<i32>,
    /// Head vertices: azimuth φ in (−π, π].
    pub phi: Vec<f64>,
    /// Ear and tongue vertices: parameter along the chain, 0 at the root, 1 at the tip.
    pub chain_t: Vec<f64>,
    /// Head vertices near an eye: (side, lid weight, share of the upper lid).
    pub lid: Vec<Option<(usize, f64, f64)>>,
    pub eyes: [EyeGeom; 2],
    pub ears: [EarGeom; 2],
    /// Tongue root (back end) and length along +z.
    pub tongue_root: V3,
    pub tongue_len: f64,
    pub head_count: usize,
}

pub(crate) fn ring_theta(i: usize) -> f64 {
    PI * (i as f64 + 1.0) / (RINGS as f64 + 1.0)
}

pub(crate) fn seg_phi(j: usize) -> f64 {
    let p = 2.0 * PI * j as f64 / SEGS as f64;
    if p > PI {
        p - 2.0 * PI
    } else {
        p
    }
}

impl HeadParams {
    fn new(rng: &mut impl Rng) -> HeadParams {
        let mut j = |x: f64, rel: f64| x * (1.0 + rng.gen_range(-rel..rel));
        HeadParams {
            rx: j(12.0, 0.03),
            ry: j(11.0, 0.03),
            rz: j(12.0, 0.03),
            snout: j(9.0, 0.08),
            drop: j(2.0, 0.2),
            narrow: j(0.3, 0.1),
            ear_len: j(15.0, 0.1),
            eye_r: j(2.6, 0.05),
            mouth_phi: j(0.75, 0.05),
        }
    }

    /// Analytic head surface at (θ, φ) (see the module doc).
    pub(crate) fn surface(&self, theta: f64, phi: f64) -> V3 {
        let d = [theta.sin() * phi.sin(), theta.cos(), theta.sin() * phi.cos()];
        let s = smoothstep(0.2, 1.0, d[2]);
        let x = self.rx * d[0] * (1.0 - self.narrow * s);
        let mut y = self.ry * d[1];
        if d[1] < 0.0 {
            y *= 0.9;
        }
        y -= self.drop * s;
        let mut z = self.rz * d[2];
        if d[2] < 0.0 {
            z *= 1.08;
        }
        z += self.snout * s.powf(1.5);
        [x, y, z]
    }

    /// Approximate outward direction at a surface point.
    pub(crate) fn outward(&self, p: V3) -> V3 {
        normalize(sub(p, [0.0, 0.0, 3.0]))
    }
}

impl Mesh {
    pub(crate) fn new(rng: &mut impl Rng) -> Mesh {
        let params = HeadParams::new(rng);
        let mut m = Mesh {
            eyes: [eye_geom(&params, 1.0), eye_geom(&params, -1.0)],
            ears: [ear_geom(&params, 1.0), ear_geom(&params, -1.0)],
            params,
            pos: Vec::new(),
            tris: Vec::new(),
            normals: Vec::new(),
            part: Vec::new(),
            ranges: Vec::new(),
            ring: Vec::new(),
            phi: Vec::new(),
            chain_t: Vec::new(),
            lid: Vec::new(),
            tongue_root: [0.0; 3],
            tongue_len: 4.8,
            head_count: 0,
        };
        m.build_head();
        for side in 0..2 {
            m.build_ear(side);
        }
        for side in 0..2 {
            m.build_eye(side);
        }
        m.build_tongue();
        m.compute_normals();
        m
    }

    fn push(&mut self, p: V3, part: Part, ring: i32, phi: f64, t: f64) -> u32 {
        self.pos.push(p);
        self.part.push(part);
        self.ring.push(ring);
        self.phi.push(phi);
        self.chain_t.push(t);
        self.lid.push(None);
        (self.pos.len() - 1) as u32
    }

    fn build_head(&mut self) {
        let p = self.params.clone();
        let dtheta = PI / (RINGS as f64 + 1.0);
        let mouth_prof = |phi: f64| 1.0 - smoothstep(p.mouth_phi, p.mouth_phi + 0.25, phi.abs());
        self.push(p.surface(0.0, 0.0), Part::Head, -1, 0.0, 0.0);
        for i in 0..RINGS {
            for j in 0..SEGS {
                let phi = seg_phi(j);
                let mut theta = ring_theta(i);
                if i == MOUTH_RING + 1 {
                    // Pull the lower lip up so the closed mouth is a thin slit.
                    theta -= 0.7 * dtheta * mouth_prof(phi);
                }
                self.push(p.surface(theta, phi), Part::Head, i as i32, phi, 0.0);
            }
        }
        self.push(p.surface(PI, 0.0), Part::Head, RINGS as i32, 0.0, 0.0);
        let n = self.pos.len();
        self.head_count = n;
        // Eye sockets: the eyeball pokes through the skin. Skin just outside it hugs the
        // eyeball (a lid rim at radius r + 0.15); the skin cap inside the eyeball stays hidden
        // there. All of it is weighted to the lids, which rotate about the eye centre.
        for side in 0..2 {
            let e = self.eyes[side].clone();
            for v in 0..n {
                let u = sub(self.pos[v], e.centre);
                let d0 = norm(u);
                let reach = e.radius + 2.6;
                if d0 < reach {
                    let t = smoothstep(e.radius + 0.9, reach, d0);
                    let dir = normalize(u);
                    if d0 >= e.radius {
                        let r = lerp(e.radius + 0.15, d0, t);
                        self.pos[v] = add(e.centre, scale(dir, r));
                    }
                    let up_share = smoothstep(-0.35, 0.35, dot(dir, e.up));
                    self.lid[v] = Some((side, 1.0 - t, up_share));
                }
            }
        }
        // Triangles.
        let idx = |i: usize, j: usize| (1 + i * SEGS + (j % SEGS)) as u32;
        let bottom = (n - 1) as u32;
        let mut tris = Vec::new();
        for j in 0..SEGS {
            tris.push([0, idx(0, j), idx(0, j + 1)]);
            tris.push([idx(RINGS - 1, j), bottom, idx(RINGS - 1, j + 1)]);
        }
        for i in 0..RINGS - 1 {
            for j in 0..SEGS {
                let in_mouth =
                    i == MOUTH_RING && seg_phi(j).abs() <= p.mouth_phi && seg_phi((j + 1) % SEGS).abs() <= p.mouth_phi;
                if in_mouth {
                    continue;
                }
                let (a, b, c, d) = (idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1));
                tris.push([a, c, d]);
                tris.push([a, d, b]);
            }
        }
        self.tris = tris;
        self.ranges.push(("head", 0..n));
    }

    fn build_ear(&mut self, side: usize) {
        let e = self.ears[side].clone();
        let start = self.pos.len();
        let sv = normalize(cross(e.dir, [0.0, 1.0, 0.0]));
        let nv = normalize(cross(sv, e.dir));
        let part = Part::Ear(side);
        for k in 0..EAR_RINGS {
            let t = k as f64 / EAR_RINGS as f64;
            let w = 3.4 * (1.0 - t).powf(0.8) + 0.25;
            let th = 0.5 * (1.0 - t) + 0.12;
            let c = add(add(e.root, scale(e.dir, e.length * t)), [0.0, -1.2 * t * t, 0.0]);
            for q in 0..EAR_RING_VERTS {
                let a = 2.0 * PI * q as f64 / EAR_RING_VERTS as f64;
                let p = add(add(c, scale(sv, w * a.cos())), scale(nv, th * a.sin()));
                self.push(p, part, i32::MIN, 0.0, t);
            }
        }
        let tip = add(add(e.root, scale(e.dir, e.length)), [0.0, -1.2, 0.0]);
        let tip = self.push(tip, part, i32::MIN, 0.0, 1.0);
        let idx = |k: usize, q: usize| (start + k * EAR_RING_VERTS + q % EAR_RING_VERTS) as u32;
        for k in 0..EAR_RINGS - 1 {
            for q in 0..EAR_RING_VERTS {
                let (a, b, c, d) = (idx(k, q), idx(k, q + 1), idx(k + 1, q), idx(k + 1, q + 1));
                self.tris.push([a, b, d]);
                self.tris.push([a, d, c]);
            }
        }
        for q in 0..EAR_RING_VERTS {
            self.tris.push([idx(EAR_RINGS - 1, q), idx(EAR_RINGS - 1, q + 1), tip]);
        }
        self.ranges.push((["ear_L", "ear_R"][side], start..self.pos.len()));
    }

    /// UV ellipsoid with its poles on ±z, appended; returns the first vertex index.
    fn push_ellipsoid(
        &mut self,
        centre: V3,
        half: V3,
        rings: usize,
        segs: usize,
        part: Part,
        chain: impl Fn(V3) -> f64,
    ) -> usize {
        let start = self.pos.len();
        let add_v = |m: &mut Mesh, d: V3| {
            let p = add(centre, [d[0] * half[0], d[1] * half[1], d[2] * half[2]]);
            m.push(p, part, i32::MIN, 0.0, chain(p));
        };
        add_v(self, [0.0, 0.0, 1.0]);
        for k in 0..rings {
            let th = PI * (k as f64 + 1.0) / (rings as f64 + 1.0);
            for q in 0..segs {
                let ph = 2.0 * PI * q as f64 / segs as f64;
                add_v(self, [th.sin() * ph.sin(), th.sin() * ph.cos(), th.cos()]);
            }
        }
        add_v(self, [0.0, 0.0, -1.0]);
        let back = (self.pos.len() - 1) as u32;
        let idx = |k: usize, q: usize| (start + 1 + k * segs + q % segs) as u32;
        for q in 0..segs {
            self.tris.push([start as u32, idx(0, q + 1), idx(0, q)]);
            self.tris.push([idx(rings - 1, q), idx(rings - 1, q + 1), back]);
        }
        for k in 0..rings - 1 {
            for q in 0..segs {
                let (a, b, c, d) = (idx(k, q), idx(k, q + 1), idx(k + 1, q), idx(k + 1, q + 1));
                self.tris.push([a, c, d]);
                self.tris.push([a, d, b]);
            }
        }
        start
    }

    fn build_eye(&mut self, side: usize) {
        let e = self.eyes[side].clone();
        let r = e.radius;
        let start = self.push_ellipsoid(e.centre, [r, r, r], EYE_RINGS, EYE_SEGS, Part::Eye(side), |_| 0.0);
        self.ranges.push((["eye_L", "eye_R"][side], start..self.pos.len()));
    }

    fn build_tongue(&mut self) {
        // Lower-lip midpoint: ring MOUTH_RING + 1, segment 0.
        let lip = self.pos[1 + (MOUTH_RING + 1) * SEGS];
        let half = [1.5, 0.45, self.tongue_len / 2.0];
        let centre = [0.0, lip[1] - 1.6, lip[2] - 6.5];
        let root_z = centre[2] - half[2];
        self.tongue_root = [0.0, centre[1], root_z];
        let len = self.tongue_len;
        let start = self.push_ellipsoid(centre, half, TONGUE_RINGS, TONGUE_SEGS, Part::Tongue, |p| {
            ((p[2] - root_z) / len).clamp(0.0, 1.0)
        });
        self.ranges.push(("tongue", start..self.pos.len()));
    }

    fn compute_normals(&mut self) {
        let mut nrm = vec![[0.0; 3]; self.pos.len()];
        for t in &self.tris {
            let [a, b, c] = t.map(|i| self.pos[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            for &i in t {
                nrm[i as usize] = add(nrm[i as usize], n);
            }
        }
        for (v, n) in nrm.iter_mut().enumerate() {
            let fallback = match self.part[v] {
                Part::Eye(s) => normalize(sub(self.pos[v], self.eyes[s].centre)),
                _ => self.params.outward(self.pos[v]),
            };
            *n = normalize_or(*n, fallback);
        }
        self.normals = nrm;
    }

    /// Index of the head vertex nearest to `p`.
    pub(crate) fn nearest_head_vertex(&self, p: V3) -> usize {
        (0..self.head_count)
            .min_by(|&a, &b| dist(self.pos[a], p).total_cmp(&dist(self.pos[b], p)))
            .expect("head has vertices")
    }
}

fn eye_geom(p: &HeadParams, sx: f64) -> EyeGeom {
    let surf = p.surface(0.38 * PI, sx * 0.85);
    let out = p.outward(surf);
    let centre = sub(surf, scale(out, 1.5));
    let axis = normalize(add(scale(out, 0.6), [0.0, 0.0, 0.4]));
    let up = normalize(sub([0.0, 1.0, 0.0], scale(axis, axis[1])));
    let side = cross(up, axis);
    EyeGeom { centre, radius: p.eye_r, axis, up, side }
}

fn ear_geom(p: &HeadParams, sx: f64) -> EarGeom {
    let surf = p.surface(0.30 * PI, sx * 2.0);
    let root = sub(surf, scale(p.outward(surf), 0.8));
    EarGeom { root, dir: normalize([sx * 0.5, 0.45, -0.75]), length: p.ear_len }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn mesh_is_well_formed() {
        let m = Mesh::new(&mut ChaCha8Rng::seed_from_u64(7));
        let n = m.pos.len();
        assert!(m.head_count >= 3000, "{}", m.head_count);
        assert!(m.tris.iter().all(|t| t.iter().all(|&i| (i as usize) < n)));
        assert!(m.tris.iter().all(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
        // The mouth slit removed some head triangles.
        let head_tris = m.tris.iter().filter(|t| (t[0] as usize) < m.head_count).count();
        assert!(head_tris <= 2 * RINGS * SEGS - 20, "{head_tris}");
        // Head about 30 cm long, eyes on the left/right of the snout.
        let (zmin, zmax) =
            m.pos[..m.head_count].iter().fold((f64::MAX, f64::MIN), |a, p| (a.0.min(p[2]), a.1.max(p[2])));
        assert!((28.0..40.0).contains(&(zmax - zmin)), "{zmin} {zmax}");
        assert!(m.eyes[0].centre[0] > 3.0 && m.eyes[1].centre[0] < -3.0);
        // Head normals point outwards for almost all vertices.
        let outward = (0..m.head_count).filter(|&v| dot(m.normals[v], m.params.outward(m.pos[v])) > 0.0).count();
        assert!(outward as f64 > 0.95 * m.head_count as f64, "{outward}");
        assert_eq!(m.ranges.len(), 6);
        assert_eq!(m.ranges.last().unwrap().1.end, n);
    }
}
