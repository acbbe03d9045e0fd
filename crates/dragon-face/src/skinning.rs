//! Bone layer: a 33-bone hierarchy and smooth linear blend skinning (LBS).
//!
//! Every bone has a pivot `c` (cm, in the rest frame, where all bones are axis-aligned) and
//! six channels: rotation angles `(rx, ry, rz)` in degrees and a translation `t` in cm. Each
//! channel is `Σ gain · (p − p_default)` over the controls driving it. Local transform
//! `L = T(c + t) · Rz·Ry·Rx · T(−c)`, global `G_b = G_parent · L_b` (bind pose = identity),
//! and a vertex moves to `v' = Σ_b w_vb · G_b · v` with at most four weights summing to 1.
//! Tongue and nostril bones carry tiny skin weights (6 % and ≤ 4 %): large rotations of
//! them barely move the mesh. Eyeball vertices have weight 1 on their eye bone, so they rotate rigidly with yaw/pitch.

use crate::controls::{BROW_BONES, EAR_BONES, SIDES, TONGUE_BONES};
use crate::math::*;
use crate::mesh::{ring_theta, Mesh, Part, MOUTH_RING, RINGS};
use std::f64::consts::PI;

#[derive(Clone, Debug)]
pub(crate) struct Bone {
    pub name: String,
    pub parent: Option<usize>,
    pub pivot: V3,
    /// (control index, channel 0..6 = rx ry rz tx ty tz, gain, control default).
    pub drives: Vec<(usize, usize, f64, f64)>,
}

/// Skeleton plus per-vertex weights in compressed rows.
#[derive(Clone, Debug)]
pub(crate) struct Skin {
    pub bones: Vec<Bone>,
    offsets: Vec<u32>,
    bone_of: Vec<u16>,
    weight: Vec<f64>,
    pub head_bone: usize,
}

pub(crate) const MAX_INFLUENCES: usize = 4;
/// Share of the tongue's skin that follows the tongue bones (the rest follows the jaw).
const TONGUE_WEIGHT: f64 = 0.06;

impl Skin {
    /// Build the skeleton and weights. `ctl(name)` gives (index, default) of a control.
    pub(crate) fn new(mesh: &Mesh, ctl: &dyn Fn(&str) -> (usize, f64)) -> Skin {
        let mut bones: Vec<Bone> = Vec::new();
        let mut add_bone = |name: &str, parent: Option<usize>, pivot: V3, drives: Vec<(String, usize, f64)>| {
            let drives = drives
                .into_iter()
                .map(|(n, ch, g)| {
                    let (i, d) = ctl(&n);
                    (i, ch, g, d)
                })
                .collect();
            bones.push(Bone { name: name.to_string(), parent, pivot, drives });
            bones.len() - 1
        };
        let rot3 = |base: &str, gy: f64, gz: f64| {
            vec![(format!("{base}_rx"), 0, 1.0), (format!("{base}_ry"), 1, gy), (format!("{base}_rz"), 2, gz)]
        };

        let p = &mesh.params;
        let neck = {
            let d = rot3("neck", 1.0, 1.0);
            add_bone("neck", None, [0.0, -9.0, -5.0], d)
        };
        let head = {
            let mut d = rot3("head", 1.0, 1.0);
            for (ch, ax) in ["tx", "ty", "tz"].iter().enumerate() {
                d.push((format!("head_{ax}"), 3 + ch, 1.0));
            }
            add_bone("head", Some(neck), [0.0, -4.0, -2.0], d)
        };
        let corner = p.surface(ring_theta(MOUTH_RING), p.mouth_phi);
        let jaw_pivot = [0.0, corner[1] + 0.5, corner[2] - 8.0];
        let jaw = add_bone(
            "jaw",
            Some(head),
            jaw_pivot,
            [("jaw_open", 0), ("jaw_side", 1), ("jaw_twist", 2), ("jaw_fwd", 5)]
                .iter()
                .map(|&(n, c)| (n.to_string(), c, 1.0))
                .collect(),
        );
        let mut parent = jaw;
        let mut tongue = Vec::new();
        for i in 0..TONGUE_BONES {
            let pivot = add(mesh.tongue_root, [0.0, 0.0, mesh.tongue_len * i as f64 / TONGUE_BONES as f64]);
            let d = rot3(&format!("tongue_{:02}", i + 1), 1.0, 1.0);
            parent = add_bone(&format!("tongue_{:02}", i + 1), Some(parent), pivot, d);
            tongue.push(parent);
        }
        let mut nostrils = Vec::new();
        for (s, sx) in SIDES {
            let c = p.surface(0.42 * PI, sx * 0.12);
            for i in 0..2 {
                let pivot = add(c, [sx * (i as f64 - 0.5) * 0.8, 0.0, -0.5]);
                let name = format!("nostril_{s}_{:02}", i + 1);
                let d = rot3(&name, sx, sx);
                nostrils.push((add_bone(&name, Some(head), pivot, d), pivot));
            }
        }
        let mut ears = Vec::new();
        for (side, (s, sx)) in SIDES.iter().enumerate() {
            let e = &mesh.ears[side];
            let mut parent = head;
            let mut chain = Vec::new();
            for i in 0..EAR_BONES {
                let t = i as f64 / EAR_BONES as f64;
                let pivot = add(add(e.root, scale(e.dir, e.length * t)), [0.0, -1.2 * t * t, 0.0]);
                let name = format!("ear_{s}_{:02}", i + 1);
                let d = rot3(&name, *sx, *sx);
                parent = add_bone(&name, Some(parent), pivot, d);
                chain.push(parent);
            }
            ears.push(chain);
        }
        let mut brows = Vec::new();
        for (side, (s, sx)) in SIDES.iter().enumerate() {
            let e = &mesh.eyes[side];
            for (k, seg) in BROW_BONES.iter().enumerate() {
                let u = (k as f64 - 1.0) * 0.8;
                let target = add(add(e.centre, scale(e.up, e.radius + 2.2)), [sx * u * 2.4, -0.3 * u * u, -u * 0.8]);
                let pivot = mesh.pos[mesh.nearest_head_vertex(target)];
                let d = vec![(format!("brow_{s}_{seg}_ty"), 4, 1.0), (format!("brow_{s}_{seg}_rz"), 2, *sx)];
                brows.push((add_bone(&format!("brow_{s}_{seg}"), Some(head), pivot, d), side));
            }
        }
        let mut lids = Vec::new();
        for (side, (s, sx)) in SIDES.iter().enumerate() {
            let c = mesh.eyes[side].centre;
            let blink = format!("eyelid_{s}_blink");
            let up = vec![
                (format!("eyelid_{s}_upper_rx"), 0, 1.0),
                (format!("eyelid_{s}_upper_rz"), 2, *sx),
                (blink.clone(), 0, 60.0),
            ];
            let lo = vec![
                (format!("eyelid_{s}_lower_rx"), 0, 1.0),
                (format!("eyelid_{s}_lower_rz"), 2, *sx),
                (blink, 0, -32.0),
            ];
            let u = add_bone(&format!("lid_{s}_upper"), Some(head), c, up);
            let l = add_bone(&format!("lid_{s}_lower"), Some(head), c, lo);
            lids.push((u, l));
        }
        let mut eyes = Vec::new();
        for (side, (s, _)) in SIDES.iter().enumerate() {
            let d = vec![(format!("eye_{s}_yaw"), 1, 1.0), (format!("eye_{s}_pitch"), 0, -1.0)];
            eyes.push(add_bone(&format!("eye_{s}"), Some(head), mesh.eyes[side].centre, d));
        }

        // Weights.
        let dtheta = PI / (RINGS as f64 + 1.0);
        let theta_m = ring_theta(MOUTH_RING);
        let mut offsets = vec![0u32];
        let mut bone_of = Vec::new();
        let mut weight = Vec::new();
        for v in 0..mesh.pos.len() {
            let pos = mesh.pos[v];
            let mut infl: Vec<(usize, f64)> = Vec::new();
            let mut root = head;
            match mesh.part[v] {
                Part::Head => {
                    let ring = mesh.ring[v];
                    let a = mesh.phi[v].abs();
                    let theta = match ring {
                        r if r < 0 => 0.0,
                        r if r >= RINGS as i32 => PI,
                        r => ring_theta(r as usize),
                    };
                    if ring > MOUTH_RING as i32 {
                        // Jaw: everything below the mouth line in front of the hinge, fading
                        // towards the mouth corners, the cheeks and back to the throat.
                        let k = smoothstep(p.mouth_phi - 0.05, p.mouth_phi + 0.3, a);
                        let below = lerp(1.0, smoothstep(theta_m, theta_m + 5.0 * dtheta, theta), k);
                        let side = 1.0 - smoothstep(p.mouth_phi - 0.5, p.mouth_phi + 0.7, a);
                        let front = smoothstep(jaw_pivot[2] - 4.0, jaw_pivot[2] + 3.0, pos[2]);
                        infl.push((jaw, below * side * front));
                    }
                    let wn = 0.5 * smoothstep(0.78 * PI, 0.98 * PI, theta) * (0.5 - 0.5 * mesh.phi[v].cos());
                    infl.push((neck, wn));
                    let lid_w = mesh.lid[v].map_or(0.0, |l| l.1);
                    for &(b, side) in &brows {
                        let cy = mesh.eyes[side].centre[1];
                        let m = smoothstep(cy, cy + 2.5, pos[1]) * (1.0 - lid_w);
                        infl.push((b, 0.8 * falloff(dist(pos, bones[b].pivot), 4.5) * m));
                    }
                    if let Some((side, lw, up_share)) = mesh.lid[v] {
                        infl.push((lids[side].0, lw * up_share));
                        infl.push((lids[side].1, lw * (1.0 - up_share)));
                    }
                    for &(b, c) in &nostrils {
                        infl.push((b, 0.04 * falloff(dist(pos, c), 1.5)));
                    }
                }
                Part::Ear(side) => {
                    root = chain_weights(&ears[side], mesh.chain_t[v], &mut infl);
                }
                Part::Tongue => {
                    // The tongue rides on the jaw; its own bones have tiny weights.
                    let b0 = chain_weights(&tongue, mesh.chain_t[v], &mut infl);
                    let used: f64 = infl.iter().map(|x| x.1).sum();
                    infl.push((b0, 1.0 - used));
                    infl.iter_mut().for_each(|x| x.1 *= TONGUE_WEIGHT);
                    root = jaw;
                }
                Part::Eye(side) => root = eyes[side],
            }
            infl.retain(|x| x.1 > 1e-6);
            let total: f64 = infl.iter().map(|x| x.1).sum();
            if total > 1.0 {
                infl.iter_mut().for_each(|x| x.1 /= total);
            } else {
                infl.push((root, 1.0 - total));
            }
            infl.sort_by(|a, b| b.1.total_cmp(&a.1));
            infl.truncate(MAX_INFLUENCES);
            infl.retain(|x| x.1 > 1e-9);
            let total: f64 = infl.iter().map(|x| x.1).sum();
            for (b, w) in infl {
                bone_of.push(b as u16);
                weight.push(w / total);
            }
            offsets.push(bone_of.len() as u32);
        }
        Skin { bones, offsets, bone_of, weight, head_bone: head }
    }

    /// Global skinning transforms for a control vector (parents precede children).
    pub(crate) fn pose(&self, controls: &[f64], out: &mut Vec<Affine>) {
        out.clear();
        for b in &self.bones {
            let mut ch = [0.0; 6];
            for &(c, k, g, d) in &b.drives {
                ch[k] += g * (controls[c] - d);
            }
            let local = if ch == [0.0; 6] {
                Affine::IDENTITY
            } else {
                Affine::about_pivot(b.pivot, &Affine::rotation_deg(ch[0], ch[1], ch[2]), [ch[3], ch[4], ch[5]])
            };
            let g = match b.parent {
                Some(p) => out[p].mul(&local),
                None => local,
            };
            out.push(g);
        }
    }

    /// Linear blend skinning in place on xyz-interleaved positions.
    pub(crate) fn apply(&self, mats: &[Affine], pos: &mut [f64]) {
        if mats.iter().all(|m| *m == Affine::IDENTITY) {
            return;
        }
        for (v, p) in pos.chunks_exact_mut(3).enumerate() {
            let (s, e) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
            let q = [p[0], p[1], p[2]];
            let r = if e - s == 1 {
                mats[self.bone_of[s] as usize].apply(q)
            } else {
                let mut m = [[0.0; 4]; 3];
                for i in s..e {
                    let w = self.weight[i];
                    let b = &mats[self.bone_of[i] as usize].0;
                    for r in 0..3 {
                        for c in 0..4 {
                            m[r][c] += w * b[r][c];
                        }
                    }
                }
                Affine(m).apply(q)
            };
            p.copy_from_slice(&r);
        }
    }
}

/// Smooth weights along a bone chain for a vertex at parameter `t ∈ [0, 1]`: mostly the
/// bone whose segment holds `t`, blending up to half into the next bone near its pivot.
/// Returns the bone that takes the remaining weight.
fn chain_weights(chain: &[usize], t: f64, infl: &mut Vec<(usize, f64)>) -> usize {
    let n = chain.len();
    let f = t * n as f64;
    let b0 = (f.floor() as usize).min(n - 1);
    let frac = f - b0 as f64;
    if b0 + 1 < n {
        infl.push((chain[b0 + 1], 0.5 * smoothstep(0.3, 1.0, frac)));
    }
    chain[b0]
}
