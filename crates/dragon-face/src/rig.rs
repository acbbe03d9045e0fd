//! `DragonRig`: the layered face rig `e(p)` from 742 controls to 3,504 vertex positions (cm).
//!
//! Evaluation order (each layer reads the previous layer's output):
//! 1. rest mesh `x₀`;
//! 2. coarse blendshapes `x += Σ w_k D_k` (sliders, incl. brows/jaw-clench/pupil sliders);
//! 3. fine blendshapes and tweak offsets `x += Σ w_k F_k`;
//! 4. correctives `x += Σ_c (Π_j ŵ_cj) C_c` on products of normalised driver controls;
//! 5. bones: linear blend skinning with 33 bones (see `skinning`);
//! 6. the 4×4×4 Bernstein FFD lattice bound to the head bone (see `lattice`).

use crate::blendshapes::{self, Corrective, Shape};
use crate::controls::{build_controls, ControlSpec};
use crate::lattice::Lattice;
use crate::math::Affine;
use crate::mesh::Mesh;
use crate::skinning::Skin;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::HashMap;
use std::ops::Range;

/// The synthetic film-style creature face rig. Cheap to clone, `Send + Sync`.
#[derive(Clone, Debug)]
pub struct DragonRig {
    seed: u64,
    controls: Vec<ControlSpec>,
    index: HashMap<String, usize>,
    mesh: Mesh,
    rest: Vec<f64>,
    coarse: Vec<Shape>,
    fine: Vec<Shape>,
    correctives: Vec<Corrective>,
    skin: Skin,
    lattice: Lattice,
}

impl DragonRig {
    /// Version of the rig's mathematics and of its generated corpus (the two travel
    /// together in the artifacts); bump whenever `evaluate` or the corpus can change.
    /// `dragonface-2`: the corpus keyed part by part with independent touch-ups.
    pub const VERSION: &'static str = "dragonface-2";

    /// Build the rig. Deterministic in `seed` (head proportions, shape amplitudes and radii).
    pub fn new(seed: u64) -> DragonRig {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let controls = build_controls();
        let index: HashMap<String, usize> = controls.iter().enumerate().map(|(i, c)| (c.name.clone(), i)).collect();
        let mesh = Mesh::new(&mut rng);
        let idx = |n: &str| *index.get(n).unwrap_or_else(|| panic!("rig control {n} missing"));
        let ctl = |n: &str| {
            let i = idx(n);
            (i, controls[i].default)
        };
        let (coarse, fine, correctives) = blendshapes::build(&mesh, &idx, &mut rng);
        let skin = Skin::new(&mesh, &ctl);
        let lattice = Lattice::new(&mesh, &ctl);
        let rest = mesh.pos.iter().flatten().copied().collect();
        DragonRig { seed, controls, index, mesh, rest, coarse, fine, correctives, skin, lattice }
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The 742 controls, in the order of every control vector.
    pub fn controls(&self) -> &[ControlSpec] {
        &self.controls
    }

    /// Index of a control by name.
    pub fn control_index(&self, name: &str) -> Option<usize> {
        self.index.get(name).copied()
    }

    /// Each control's default value (the default pose evaluates to the rest mesh).
    pub fn default_pose(&self) -> Vec<f64> {
        self.controls.iter().map(|c| c.default).collect()
    }

    pub fn vertex_count(&self) -> usize {
        self.mesh.pos.len()
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.mesh.tris
    }

    /// Rest positions (cm), xyz interleaved.
    pub fn rest_positions(&self) -> &[f64] {
        &self.rest
    }

    /// Named vertex ranges: `head`, `ear_L`, `ear_R`, `eye_L`, `eye_R`, `tongue`.
    pub fn parts(&self) -> Vec<(&'static str, Range<usize>)> {
        self.mesh.ranges.clone()
    }

    /// Names of the skeleton's bones, parents first.
    pub fn bone_names(&self) -> Vec<&str> {
        self.skin.bones.iter().map(|b| b.name.as_str()).collect()
    }

    /// Vertex positions (cm) for one control vector: `out.len() == 3 * vertex_count`, xyz
    /// interleaved. Values outside a control's range are evaluated as given (no clamping).
    ///
    /// # Panics
    /// If `controls.len() != controls().len()` or `out.len() != 3 * vertex_count()`.
    pub fn evaluate(&self, controls: &[f64], out: &mut [f64]) {
        assert_eq!(controls.len(), self.controls.len(), "control vector length");
        assert_eq!(out.len(), self.rest.len(), "output length must be 3 * vertex_count");
        out.copy_from_slice(&self.rest);
        for s in self.coarse.iter().chain(&self.fine) {
            let w = controls[s.control] - self.controls[s.control].default;
            if w != 0.0 {
                s.field.add_scaled(w, out);
            }
        }
        for c in &self.correctives {
            let w = c.weight(controls);
            if w != 0.0 {
                c.field.add_scaled(w, out);
            }
        }
        let mut mats: Vec<Affine> = Vec::with_capacity(self.skin.bones.len());
        self.skin.pose(controls, &mut mats);
        self.skin.apply(&mats, out);
        self.lattice.apply(controls, &mats[self.skin.head_bone], out);
    }

    /// Convenience: evaluate into a new vector.
    pub fn evaluate_vec(&self, controls: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.rest.len()];
        self.evaluate(controls, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    fn rig() -> DragonRig {
        DragonRig::new(7)
    }

    fn moved(a: &[f64], b: &[f64], v: usize) -> f64 {
        let d: f64 = (0..3).map(|k| (a[3 * v + k] - b[3 * v + k]).powi(2)).sum();
        d.sqrt()
    }

    fn set(rig: &DragonRig, p: &mut [f64], name: &str, v: f64) {
        p[rig.control_index(name).unwrap()] = v;
    }

    #[test]
    fn rig_shape_and_determinism() {
        let a = rig();
        let b = DragonRig::new(7);
        let c = DragonRig::new(8);
        assert_eq!(a.controls().len(), 742);
        let names: HashSet<_> = a.controls().iter().map(|c| &c.name).collect();
        assert_eq!(names.len(), 742);
        assert!(a.vertex_count() >= 3000);
        assert!(a.triangles().len() > 5000);
        let n = a.vertex_count() as u32;
        assert!(a.triangles().iter().flatten().all(|&i| i < n));
        let mut p = a.default_pose();
        set(&a, &mut p, "smile_L", 0.7);
        set(&a, &mut p, "jaw_open", 20.0);
        set(&a, &mut p, "head_ry", 15.0);
        set(&a, &mut p, "lattice_223_tz", 1.0);
        assert_eq!(a.evaluate_vec(&p), b.evaluate_vec(&p), "same seed, same mesh");
        assert_ne!(a.evaluate_vec(&p), c.evaluate_vec(&p), "seed changes the rig");
        fn assert_send_sync_clone<T: Send + Sync + Clone>() {}
        assert_send_sync_clone::<DragonRig>();
    }

    #[test]
    fn default_pose_is_rest_mesh_and_evaluation_is_finite() {
        let r = rig();
        let out = r.evaluate_vec(&r.default_pose());
        assert!(out == r.rest_positions(), "default pose must reproduce the rest mesh exactly");
        // Every control at its max, then at its min: still finite and different from rest.
        for pick in [|c: &ControlSpec| c.max, |c: &ControlSpec| c.min] {
            let p: Vec<f64> = r.controls().iter().map(pick).collect();
            let out = r.evaluate_vec(&p);
            assert!(out.iter().all(|x| x.is_finite()));
            assert!(out.iter().zip(r.rest_positions()).any(|(a, b)| (a - b).abs() > 1.0));
        }
    }

    #[test]
    fn jaw_open_moves_lower_face_not_top_of_head() {
        let r = rig();
        let rest = r.evaluate_vec(&r.default_pose());
        let mut p = r.default_pose();
        set(&r, &mut p, "jaw_open", 30.0);
        let out = r.evaluate_vec(&p);
        let head = r.parts()[0].1.clone();
        let ys: Vec<f64> = head.clone().map(|v| rest[3 * v + 1]).collect();
        let ymax = ys.iter().cloned().fold(f64::MIN, f64::max);
        // Top of the head (upper 40% by height) does not move at all.
        let top: Vec<usize> = head.clone().filter(|&v| rest[3 * v + 1] > ymax - 8.0).collect();
        assert!(top.len() > 100);
        assert!(top.iter().all(|&v| moved(&rest, &out, v) < 1e-12));
        // The chin (lowest front vertices) drops by several cm.
        let chin = head
            .clone()
            .filter(|&v| rest[3 * v + 2] > 12.0 && rest[3 * v + 1] < -4.0)
            .map(|v| moved(&rest, &out, v))
            .fold(0.0, f64::max);
        assert!(chin > 4.0, "chin moved {chin}");
        let below = head.filter(|&v| out[3 * v + 1] < rest[3 * v + 1] - 0.5).count();
        assert!(below > 150, "{below} vertices moved down");
    }

    #[test]
    fn eye_yaw_moves_only_the_eyeball_rigidly() {
        let r = rig();
        let rest = r.evaluate_vec(&r.default_pose());
        let eye = r.parts().into_iter().find(|p| p.0 == "eye_L").unwrap().1;
        let mut p = r.default_pose();
        set(&r, &mut p, "eye_L_yaw", 25.0);
        let out = r.evaluate_vec(&p);
        for v in 0..r.vertex_count() {
            let m = moved(&rest, &out, v);
            if eye.contains(&v) {
                // pupil (first vertex) moves; distances between eyeball vertices are preserved.
                let d0 = moved(&rest[3 * eye.start..], &rest[3 * v..], 0);
                let d1 = moved(&out[3 * eye.start..], &out[3 * v..], 0);
                assert!((d0 - d1).abs() < 1e-9);
            } else {
                assert!(m < 1e-12, "vertex {v} outside the eye moved {m}");
            }
        }
        assert!(moved(&rest, &out, eye.start) > 0.5);
        // Positive yaw looks to the character's left (+x).
        assert!(out[3 * eye.start] > rest[3 * eye.start]);
    }

    #[test]
    fn layers_all_contribute() {
        let r = rig();
        let rest = r.evaluate_vec(&r.default_pose());
        let total = |name: &str, v: f64| {
            let mut p = r.default_pose();
            set(&r, &mut p, name, v);
            let out = r.evaluate_vec(&p);
            (0..r.vertex_count()).map(|i| moved(&rest, &out, i)).sum::<f64>()
        };
        for (name, v) in [
            ("smile_L", 1.0),
            ("lip_upper_05_up", 1.0),
            ("tweak_chin_ty", 1.0),
            ("ear_R_03_rx", 30.0),
            ("brow_L_mid_ty", 1.0),
            ("eyelid_R_blink", 1.0),
            ("lattice_123_tz", 2.0),
            ("head_tx", 1.0),
            ("tongue_02_rx", 30.0),
            ("nostril_L_01_rx", 30.0),
        ] {
            assert!(total(name, v) > 1e-3, "{name} has no effect");
        }
        // Corrective: jaw_open × smile_L is more than the sum of its parts.
        let mut p = r.default_pose();
        set(&r, &mut p, "jaw_open", 35.0);
        let jaw = r.evaluate_vec(&p);
        set(&r, &mut p, "smile_L", 1.0);
        let both = r.evaluate_vec(&p);
        let mut q = r.default_pose();
        set(&r, &mut q, "smile_L", 1.0);
        let smile = r.evaluate_vec(&q);
        let nonadd = (0..both.len()).map(|i| (both[i] - jaw[i] - smile[i] + rest[i]).abs()).fold(0.0, f64::max);
        assert!(nonadd > 0.3, "corrective missing: {nonadd}");
    }

    #[test]
    #[ignore = "benchmark: cargo test --release -p reprise-dragon-face -- --ignored --nocapture"]
    fn bench_evaluate() {
        use rand::Rng;
        let r = rig();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let poses: Vec<Vec<f64>> = (0..200)
            .map(|_| {
                r.controls()
                    .iter()
                    .map(|c| if c.group == "tweak" { 0.0 } else { rng.gen_range(c.min..c.max) * 0.5 })
                    .collect()
            })
            .collect();
        let mut out = vec![0.0; 3 * r.vertex_count()];
        let t = std::time::Instant::now();
        let reps = 20;
        for _ in 0..reps {
            for p in &poses {
                r.evaluate(p, &mut out);
            }
        }
        let per = t.elapsed().as_secs_f64() / (reps * poses.len()) as f64;
        println!("evaluate: {:.1} µs per pose (all controls non-zero)", per * 1e6);
        let front: Vec<Vec<f64>> = poses
            .iter()
            .map(|p| {
                p.iter()
                    .zip(r.controls())
                    .map(|(v, c)| {
                        // keep only the front lattice layer (k = 3), as in the corpus
                        let back_lattice = c.group == "lattice" && c.name.as_bytes()[10] != b'3';
                        if back_lattice {
                            0.0
                        } else {
                            *v
                        }
                    })
                    .collect()
            })
            .collect();
        let t = std::time::Instant::now();
        for _ in 0..reps {
            for p in &front {
                r.evaluate(p, &mut out);
            }
        }
        let per = t.elapsed().as_secs_f64() / (reps * poses.len()) as f64;
        println!("evaluate, only the 16 front lattice points: {:.1} µs per pose", per * 1e6);
        for group in ["lattice", "shapes_fine", "shapes_coarse"] {
            let ps: Vec<Vec<f64>> = poses
                .iter()
                .map(|p| p.iter().zip(r.controls()).map(|(v, c)| if c.group == group { 0.0 } else { *v }).collect())
                .collect();
            let t = std::time::Instant::now();
            for _ in 0..reps {
                for p in &ps {
                    r.evaluate(p, &mut out);
                }
            }
            let per = t.elapsed().as_secs_f64() / (reps * poses.len()) as f64;
            println!("evaluate without {group}: {:.1} µs per pose", per * 1e6);
        }
        let corpus = crate::generate_corpus(&r, 7);
        let t = std::time::Instant::now();
        let mut n = 0;
        for take in &corpus.takes {
            for f in 0..take.frame_count {
                r.evaluate(take.frame(f), &mut out);
                n += 1;
            }
        }
        let per = t.elapsed().as_secs_f64() / n as f64;
        println!("evaluate, all {n} corpus frames: {:.1} µs per pose", per * 1e6);
        let support: usize = r.coarse.iter().chain(&r.fine).map(|s| s.field.idx.len()).sum();
        println!("blendshape support total: {support}");
        let t = std::time::Instant::now();
        let _ = DragonRig::new(7);
        println!("DragonRig::new: {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    }
}
