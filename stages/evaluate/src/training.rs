//! The training data's reference values that every metric is measured against, computed
//! once, the same for every system: motion percentiles on meshes, the median frame step,
//! and the reference sets of plausibility — the training frames as they are (`raw`), and
//! each projected through its own label's PCA (`projected`: the poses a PCA-based model
//! reproduces exactly). The floor-matched measure is the distance to the nearer of the two,
//! so a system that replays training frames and one that synthesises through the PCA both
//! score 0 on what their representation reproduces exactly.

use rayon::prelude::*;
use reprise_artifact::frames::LabeledFrames;
use reprise_motion_metrics::{
    nearest_k, peak_speeds, peaks, quantile, rms_speeds, squared_distance, squared_distance_f32, squared_distance_f32s,
};
use reprise_numerics::gplvm::RigMap;
use reprise_stagekit::rig::{mesh_rmse, meshes};
use reprise_stagekit::{StageError, StageResult};

/// The rig the meshes are evaluated through.
pub type RigRef<'a> = &'a (Box<dyn reprise_rig::Rig>, reprise_rig::PoseLayout);

/// Candidates, nearest in scaled control space, among which the mesh-space nearest frame
/// is sought (the scaled space is built to approximate mesh distances; this keeps the
/// search linear in the corpus).
pub const MESH_CANDIDATES: usize = 32;

/// A set of reference poses in scaled control space and on the mesh.
#[derive(Debug, Clone, Default)]
pub struct Reference {
    /// Scaled controls $z = \bar w \odot p$, `N × C`.
    pub z: Vec<f64>,
    /// Vertex positions, `N × 3V` (single precision: distances are reported to 3 digits).
    pub mesh: Vec<f32>,
    /// Coordinates $U^\top(z - \bar z)$ in the search basis ([`Training::basis`]), `N × r`,
    /// in single precision (they only order candidates; see [`Reference::slack`]).
    pub reduced: Vec<f32>,
    /// The largest magnitude of the coordinates in `reduced` (sets the single-precision
    /// slack, [`Reference::slack`]).
    pub max_abs: f64,
}

/// The training data's reference values.
#[derive(Debug, Clone)]
pub struct Training {
    /// Frames per second.
    pub fps: f64,
    /// Mesh values per frame, $3V$.
    pub dim: usize,
    /// Scaled-space weights $\bar w$ (mean over labels).
    pub weight: Vec<f64>,
    /// 95th percentile of per-frame peak vertex acceleration (mesh units/s²).
    pub acc95: f64,
    /// 95th percentile of per-frame peak vertex jerk (mesh units/s³).
    pub jerk95: f64,
    /// 99th percentile of per-frame peak vertex speed (mesh units/s).
    pub speed99: f64,
    /// Median distance between consecutive training frames in scaled control space.
    pub step: f64,
    /// Median RMS vertex distance between consecutive training frames (mesh units).
    pub mesh_step: f64,
    /// The training frames.
    pub raw: Reference,
    /// The training frames, each projected through its own label's PCA.
    pub projected: Reference,
    /// The search basis: the training frames' top principal directions in scaled space
    /// (at most [`SEARCH_BASIS`]), used only to order candidates (distances stay exact).
    pub basis: Option<reprise_numerics::pca::Pca>,
    /// Labels, in order of first appearance.
    pub labels: Vec<String>,
    /// Label (index into `labels`) of every training row (the same rows in `raw` and
    /// `projected`).
    pub row_label: Vec<usize>,
    /// Per label, the per-frame RMS vertex speeds of its training frames (mesh units/s),
    /// ascending: the liveliness reference.
    pub speeds: Vec<Vec<f64>>,
}

/// Dimension of the search basis of [`Reference::nearest`].
pub const SEARCH_BASIS: usize = 48;

/// One frame's distance to a reference set, in both spaces (unnormalised).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// Scaled control space (mesh length).
    pub scaled: f64,
    /// RMS vertex distance to the nearest of the [`MESH_CANDIDATES`] (mesh units).
    pub mesh: f64,
    /// The training row of that mesh-nearest pose (`None` for an empty set).
    pub row: Option<usize>,
}

impl Reference {
    /// Distance from a pose (scaled controls `z`, its search-basis coordinates `y`, mesh
    /// `m`) to the set. Exact: the [`MESH_CANDIDATES`] nearest in scaled space are found by
    /// visiting the set in order of the distance in the orthonormal search basis — a lower
    /// bound of the full distance — and stopping once the bound exceeds the k-th best.
    pub fn nearest(&self, z: &[f64], y: &[f64], m: &[f64]) -> Nearest {
        let near = self.candidates(z, y);
        let scaled = near.first().map_or(f64::INFINITY, |n| n.0);
        // Candidates come nearest in scaled space first, which is built to approximate the
        // mesh distance: the best on the mesh is usually among the first, and every later
        // one stops summing once it is past it.
        let mut best: Option<(usize, f64)> = None;
        for &(_, i) in &near {
            let limit = best.map_or(f64::INFINITY, |b| b.1);
            if let Some(sq) = self.mesh_sq_distance_below(i, m, limit) {
                best = Some((i, sq));
            }
        }
        let rms = |sq: f64| (sq / (m.len() / 3).max(1) as f64).sqrt();
        Nearest { scaled, mesh: best.map_or(f64::INFINITY, |b| rms(b.1)), row: best.map(|b| b.0) }
    }

    /// The mesh-nearest of the [`MESH_CANDIDATES`] scaled-space nearest rows (the pose the
    /// mesh plausibility of [`Reference::nearest`] measures against): (row, RMS vertex
    /// distance in mesh units); `None` for an empty set.
    pub fn nearest_row(&self, z: &[f64], y: &[f64], m: &[f64]) -> Option<(usize, f64)> {
        let n = self.nearest(z, y, m);
        n.row.map(|r| (r, n.mesh))
    }

    /// The [`MESH_CANDIDATES`] rows nearest to `z` in scaled space, (distance, row),
    /// nearest first. Exact: rows are visited in order of the distance in the orthonormal
    /// search basis (`y`: `z`'s coordinates there) — a lower bound of the full distance —
    /// until the bound exceeds the k-th best.
    fn candidates(&self, z: &[f64], y: &[f64]) -> Vec<(f64, usize)> {
        let (c, r) = (z.len(), y.len());
        if r == 0 {
            return nearest_k(z, &self.z, c, MESH_CANDIDATES);
        }
        let order = |a: &(f64, usize), b: &(f64, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        // Squared lower bounds of every row; only as many as the visit needs get sorted: a
        // first batch, then the rest if the batch ran out before the bound passed the k-th.
        let y32: Vec<f32> = y.iter().map(|v| *v as f32).collect();
        let slack = self.slack(y.iter().fold(0.0f64, |a, v| a.max(v.abs())), r);
        let mut bound: Vec<(f64, usize)> =
            self.reduced.chunks_exact(r).enumerate().map(|(i, row)| (squared_distance_f32s(row, &y32), i)).collect();
        let batch = (8 * MESH_CANDIDATES).min(bound.len());
        if batch < bound.len() {
            bound.select_nth_unstable_by(batch, order);
        }
        bound[..batch].sort_unstable_by(order);
        let mut best: Vec<(f64, usize)> = Vec::with_capacity(MESH_CANDIDATES + 1);
        let visit = |(lb, i): (f64, usize), best: &mut Vec<(f64, usize)>| -> bool {
            if best.len() == MESH_CANDIDATES && lb.sqrt() - slack > best[MESH_CANDIDATES - 1].0 {
                return false;
            }
            let d = squared_distance(&self.z[i * c..(i + 1) * c], z).sqrt();
            let at = best.partition_point(|&(e, j)| (e, j) < (d, i));
            best.insert(at, (d, i));
            best.truncate(MESH_CANDIDATES);
            true
        };
        let mut done = false;
        for &b in &bound[..batch] {
            if !visit(b, &mut best) {
                done = true;
                break;
            }
        }
        if !done {
            let rest = &mut bound[batch..];
            rest.sort_unstable_by(order);
            for &b in rest.iter() {
                if !visit(b, &mut best) {
                    break;
                }
            }
        }
        best
    }

    /// How far a distance computed from the single-precision coordinates (the set's, of
    /// largest magnitude $M$, and a query's, of largest magnitude $Q$) can be from the exact
    /// one, in mesh length. With $u = 2^{-24}$ (half of `f32::EPSILON` $= \varepsilon$) and
    /// $A = \max(M, Q)$: each rounded coordinate is off by at most $uA$ and the rounded
    /// difference adds $2uA$, so a distance over $r$ coordinates is off by at most
    /// $3\sqrt r\,uA$; squaring and the lane sums (depth at most $r/8 + 8$) add about
    /// $(r/8 + 10)\,u$ of the sum, at most $2\sqrt r\,A$ in distance. The slack taken,
    /// $4(2\sqrt r\,\varepsilon A + 2r\sqrt r\,\varepsilon A)$, is more than ten times that bound
    /// for every $r \ge 1$. The search stops only once a bound minus this passes the k-th
    /// best, so its result stays exact.
    pub fn slack(&self, q: f64, r: usize) -> f64 {
        let a = self.max_abs.max(q);
        let (eps, rt) = (f64::from(f32::EPSILON), (r.max(1) as f64).sqrt());
        4.0 * (2.0 * rt * eps * a + r as f64 * eps * 2.0 * a * rt)
    }

    /// The squared vertex distance $\sum (r_i - m)^2$ between row `i`'s mesh and `m`, or
    /// `None` as soon as the partial sum reaches `limit` (it cannot be below it).
    fn mesh_sq_distance_below(&self, i: usize, m: &[f64], limit: f64) -> Option<f64> {
        let dim = m.len();
        let r = &self.mesh[i * dim..(i + 1) * dim];
        let mut sq = 0.0;
        for (a, b) in r.chunks(512).zip(m.chunks(512)) {
            sq += squared_distance_f32(a, b);
            if sq >= limit {
                return None;
            }
        }
        Some(sq)
    }
}

/// `v` (`N × dim`) cut into the rows of each run; `runs` tile `0..N` in order.
fn split_runs<'a>(mut v: &'a mut [f32], runs: &[(usize, usize)], dim: usize) -> Vec<&'a mut [f32]> {
    runs.iter()
        .map(|&(s, e)| {
            let (head, tail) = std::mem::take(&mut v).split_at_mut((e - s) * dim);
            v = tail;
            head
        })
        .collect()
}

impl Training {
    /// Measures the reference values. `maps` holds each label's PCA map (for the floor);
    /// `mesh_limit` bounds the values held for the two mesh reference sets.
    pub fn measure(
        rig: RigRef<'_>,
        labeled: &LabeledFrames,
        weight: Vec<f64>,
        maps: &[(String, RigMap)],
        mesh_limit: usize,
    ) -> StageResult<Self> {
        let n = labeled.frames.rows();
        let fps = labeled.frames.fps;
        let dim = 3 * rig.0.vertex_count();
        if n.saturating_mul(dim).saturating_mul(2) > mesh_limit {
            return Err(StageError::Config(format!(
                "{n} training frames × {dim} mesh values × 2 reference sets exceed --mesh-reference-limit {mesh_limit}; \
                 raise it (memory: 4 bytes per value)"
            )));
        }
        let map_of = |label: &str| -> StageResult<&RigMap> {
            maps.iter().find(|(l, _)| l == label).map(|(_, m)| m).ok_or_else(|| {
                StageError::Input(format!("no PCA model for label `{label}` of the labeled frames; rerun pca"))
            })
        };
        let z = |p: &[f64]| -> Vec<f64> { p.iter().zip(&weight).map(|(a, w)| a * w).collect() };
        struct Segment {
            rms_speed: Vec<f64>,
            acc: Vec<f64>,
            jerk: Vec<f64>,
            speed: Vec<f64>,
            mesh_steps: Vec<f64>,
            raw_z: Vec<f64>,
            floor_z: Vec<f64>,
        }
        let runs = labeled.segment_runs();
        // The two mesh sets are written in place, run by run (the runs tile the rows in
        // order): no per-run copies to concatenate, so they are held once.
        let (mut raw_mesh, mut floor_mesh) = (vec![0f32; n * dim], vec![0f32; n * dim]);
        let (raw_parts, floor_parts) = (split_runs(&mut raw_mesh, &runs, dim), split_runs(&mut floor_mesh, &runs, dim));
        let segments: Vec<StageResult<Segment>> = runs
            .par_iter()
            .zip(raw_parts.into_par_iter().zip(floor_parts))
            .map(|(&(s, e), (raw_out, floor_out))| {
                let rows: Vec<Vec<f64>> = (s..e).map(|r| labeled.frames.row(r).to_vec()).collect();
                let map = map_of(&labeled.label[s])?;
                let mut y = vec![0.0; map.d()];
                let floor_rows: Vec<Vec<f64>> = rows
                    .iter()
                    .map(|p| {
                        let mut out = vec![0.0; p.len()];
                        map.project(p, &mut y);
                        map.apply(&y, &mut out);
                        out
                    })
                    .collect();
                // One segment's f64 meshes at a time: the floor's are written and dropped
                // before the raw ones are evaluated.
                meshes(rig, &floor_rows)?.iter().zip(floor_out.iter_mut()).for_each(|(v, o)| *o = *v as f32);
                let m = meshes(rig, &rows)?;
                let (a, j) = peaks(&m, dim, fps);
                let v = peak_speeds(&m, dim, fps);
                let mesh_steps = (1..rows.len())
                    .map(|t| mesh_rmse(&m[t * dim..(t + 1) * dim], &m[(t - 1) * dim..t * dim]))
                    .collect();
                raw_out.iter_mut().zip(&m).for_each(|(o, v)| *o = *v as f32);
                Ok(Segment {
                    rms_speed: rms_speeds(&m, dim, fps).get(1..).unwrap_or_default().to_vec(),
                    // Frames with the neighbours each difference needs (none in a run of one).
                    acc: a.get(1..a.len().saturating_sub(1)).unwrap_or_default().to_vec(),
                    jerk: j.get(1..j.len().saturating_sub(2)).unwrap_or_default().to_vec(),
                    speed: v.get(1..).unwrap_or_default().to_vec(),
                    mesh_steps,
                    raw_z: rows.iter().flat_map(|r| z(r)).collect(),
                    floor_z: floor_rows.iter().flat_map(|r| z(r)).collect(),
                })
            })
            .collect();
        let (mut acc, mut jerk, mut speed, mut mesh_steps) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut raw = Reference { mesh: raw_mesh, ..Default::default() };
        let mut floor = Reference { mesh: floor_mesh, ..Default::default() };
        let mut labels: Vec<String> = Vec::new();
        let mut row_label = Vec::with_capacity(n);
        let mut speeds: Vec<Vec<f64>> = Vec::new();
        for (s, &(start, end)) in segments.into_iter().zip(&runs) {
            let s = s?;
            let name = &labeled.label[start];
            let li = labels.iter().position(|l| l == name).unwrap_or_else(|| {
                labels.push(name.clone());
                speeds.push(Vec::new());
                labels.len() - 1
            });
            row_label.extend(std::iter::repeat_n(li, end - start));
            speeds[li].extend(s.rms_speed);
            acc.extend(s.acc);
            jerk.extend(s.jerk);
            speed.extend(s.speed);
            mesh_steps.extend(s.mesh_steps);
            raw.z.extend(s.raw_z);
            floor.z.extend(s.floor_z);
        }
        let c = weight.len();
        let params =
            reprise_numerics::pca::PcaParams { variance: 1.0, min_components: 1, max_components: SEARCH_BASIS };
        let basis = reprise_numerics::pca::Pca::fit(&raw.z, c, &params).ok();
        if let Some(b) = &basis {
            for set in [&mut raw, &mut floor] {
                let reduced: Vec<f64> = set.z.par_chunks(c).flat_map_iter(|row| b.project(row, b.kept)).collect();
                set.max_abs = reduced.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                set.reduced = reduced.iter().map(|v| *v as f32).collect();
            }
        }
        let steps: Vec<f64> = runs
            .iter()
            .flat_map(|&(s, e)| {
                let raw = &raw.z;
                (s + 1..e).map(move |r| {
                    raw[r * c..(r + 1) * c]
                        .iter()
                        .zip(&raw[(r - 1) * c..r * c])
                        .map(|(a, b)| (a - b).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
            })
            .collect();
        speeds.iter_mut().for_each(|v| v.sort_by(f64::total_cmp));
        Ok(Self {
            labels,
            row_label,
            speeds,
            fps,
            dim,
            acc95: quantile(&acc, 0.95),
            jerk95: quantile(&jerk, 0.95),
            speed99: quantile(&speed, 0.99).max(1e-12),
            step: quantile(&steps, 0.5).max(1e-12),
            mesh_step: quantile(&mesh_steps, 0.5).max(1e-12),
            weight,
            raw,
            projected: floor,
            basis,
        })
    }

    /// Coordinates of scaled controls `z` in the search basis (empty without one).
    pub fn reduce(&self, z: &[f64]) -> Vec<f64> {
        self.basis.as_ref().map_or_else(Vec::new, |b| b.project(z, b.kept))
    }

    /// Distances of a pose (controls `p`, mesh `m`) to the raw training frames and to the
    /// floor — the nearer of a training frame and a training frame projected through its
    /// own label's PCA, so a system scores 0 on any pose its representation reproduces
    /// exactly (a replayed frame, or a PCA-projected one).
    pub fn distances(&self, p: &[f64], m: &[f64]) -> (Nearest, Nearest) {
        let z = self.z(p);
        let y = self.reduce(&z);
        let raw = self.raw.nearest(&z, &y, m);
        let proj = self.projected.nearest(&z, &y, m);
        let row = if proj.mesh < raw.mesh { proj.row } else { raw.row };
        (raw, Nearest { scaled: raw.scaled.min(proj.scaled), mesh: raw.mesh.min(proj.mesh), row })
    }

    /// Index of label `name` in [`Training::labels`].
    pub fn label_index(&self, name: &str) -> Option<usize> {
        self.labels.iter().position(|l| l == name)
    }

    /// The mean per-frame RMS vertex speed of label `li`'s training frames (mesh units/s;
    /// NaN for a label without two consecutive frames).
    pub fn mean_speed(&self, li: usize) -> f64 {
        let v = &self.speeds[li];
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    }

    /// Scaled controls $z = \bar w \odot p$.
    pub fn z(&self, p: &[f64]) -> Vec<f64> {
        p.iter().zip(&self.weight).map(|(a, w)| a * w).collect()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use reprise_artifact::frames::Frames;
    use reprise_rig::linear::LinearRig;
    use reprise_rig::{Local, PoseLayout};

    /// A linear rig over controls `c0 c1 c2` with 4 vertices.
    pub(crate) fn rig() -> (Box<dyn reprise_rig::Rig>, PoseLayout) {
        let names: Vec<String> = (0..3).map(|j| format!("c{j}")).collect();
        let layout = PoseLayout::new(&names, vec![0.0; 3], &names).unwrap();
        (Box::new(Local::new(LinearRig::new(names, 4))), layout)
    }

    /// Two labels of 30 frames (one segment each): `a` moves along c0 with a small wobble
    /// in c2, `b` along c1 with the same wobble.
    pub(crate) fn labeled() -> LabeledFrames {
        let n = 30;
        let values: Vec<f64> = (0..2 * n)
            .flat_map(|r| {
                let t = (r % n) as f64 / n as f64;
                let wobble = 0.05 * (7.0 * t).sin();
                if r < n {
                    [t, 0.0, wobble]
                } else {
                    [0.0, t, wobble]
                }
            })
            .collect();
        LabeledFrames {
            segment_id: (0..2 * n).map(|r| (r / n) as i64).collect(),
            label: (0..2 * n).map(|r| if r < n { "a".into() } else { "b".into() }).collect(),
            frames: Frames {
                fps: 24.0,
                controls: (0..3).map(|j| format!("c{j}")).collect(),
                clip: (0..2 * n).map(|r| format!("clip{}", r / n)).collect(),
                frame: (0..2 * n).map(|r| (r % n) as i64).collect(),
                time: (0..2 * n).map(|r| (r % n) as f64 / 24.0).collect(),
                values,
            },
            masked_controls: vec![],
        }
    }

    /// One-component PCAs: `a` keeps c0, `b` keeps c1 (unit weights, so z = p).
    pub(crate) fn maps() -> Vec<(String, RigMap)> {
        let w = [1.0; 3];
        let map = |dir: [f64; 3], mean: [f64; 3]| RigMap::from_pca(&mean, &dir, &mean, &w).unwrap();
        vec![("a".into(), map([1.0, 0.0, 0.0], [0.5, 0.0, 0.0])), ("b".into(), map([0.0, 1.0, 0.0], [0.0, 0.5, 0.0]))]
    }

    pub(crate) fn training() -> Training {
        Training::measure(&rig(), &labeled(), vec![1.0; 3], &maps(), usize::MAX).unwrap()
    }

    /// A training frame is 0 from the raw set; projected through its own label's PCA it is
    /// 0 from the floor set but not from the raw one (the PCA drops the wobble), in both
    /// spaces.
    #[test]
    fn a_projected_training_frame_is_on_the_floor() {
        let (t, lf, rig) = (training(), labeled(), rig());
        let p = lf.frames.row(7).to_vec();
        let m = meshes(&rig, std::slice::from_ref(&p)).unwrap();
        let (on_raw, on_floor) = t.distances(&p, &m);
        assert!(on_raw.scaled < 1e-12 && on_raw.mesh < 1e-5, "{on_raw:?}");
        assert!(on_floor.scaled < 1e-12, "a replayed frame is on the floor too: {on_floor:?}");
        let (mut y, mut q) = (vec![0.0; 1], vec![0.0; 3]);
        let map = &maps()[0].1;
        map.project(&p, &mut y);
        map.apply(&y, &mut q);
        assert!((q[2]).abs() < 1e-12 && (q[0] - p[0]).abs() < 1e-12, "{q:?}");
        let m = meshes(&rig, std::slice::from_ref(&q)).unwrap();
        let (raw, floor) = t.distances(&q, &m);
        assert!(floor.scaled < 1e-12 && floor.mesh < 1e-5, "{floor:?}");
        assert!(raw.scaled > 0.01 && raw.mesh > 0.01, "the wobble is gone: {raw:?}");
    }

    /// A label of a single frame (a run without neighbours for any difference) is measured
    /// without a panic: it adds no motion percentile and has no speeds, but its frame is a
    /// reference pose with its label.
    #[test]
    fn a_one_frame_label_is_measured() {
        let mut lf = labeled();
        lf.segment_id.push(9);
        lf.label.push("c".into());
        lf.frames.clip.push("clip9".into());
        lf.frames.frame.push(0);
        lf.frames.time.push(0.0);
        lf.frames.values.extend([0.3, 0.3, 0.0]);
        let mut maps = maps();
        let w = [1.0; 3];
        maps.push(("c".into(), RigMap::from_pca(&[0.3, 0.3, 0.0], &[1.0, 0.0, 0.0], &[0.3, 0.3, 0.0], &w).unwrap()));
        let t = Training::measure(&rig(), &lf, vec![1.0; 3], &maps, usize::MAX).unwrap();
        let c = t.label_index("c").unwrap();
        assert!(t.speeds[c].is_empty() && t.mean_speed(c).is_nan());
        assert_eq!(t.row_label.last(), Some(&c));
        assert_eq!(t.raw.z.len(), 61 * 3);
    }

    /// The pruned search finds the same candidates as a full scan: random poses against a
    /// random 300-frame set in 20 dimensions, with a 5-dimensional search basis.
    #[test]
    fn the_pruned_search_is_exact() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (n, c) = (300, 20);
        let z: Vec<f64> = (0..n * c).map(|i| rng.gen::<f64>() * (1.0 + (i % c) as f64)).collect();
        let params = reprise_numerics::pca::PcaParams { variance: 1.0, min_components: 1, max_components: 5 };
        let basis = reprise_numerics::pca::Pca::fit(&z, c, &params).unwrap();
        let reduced: Vec<f64> = z.chunks(c).flat_map(|r| basis.project(r, basis.kept)).collect();
        let max_abs = reduced.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let reduced = reduced.iter().map(|v| *v as f32).collect();
        let mesh: Vec<f32> = z.iter().map(|v| *v as f32).collect();
        let set = Reference { z: z.clone(), mesh: mesh.clone(), reduced, max_abs };
        let full = Reference { z: z.clone(), mesh, reduced: vec![], max_abs: 0.0 };
        for _ in 0..50 {
            let q: Vec<f64> = (0..c).map(|j| rng.gen::<f64>() * (1.0 + j as f64)).collect();
            let y = basis.project(&q, basis.kept);
            assert_eq!(set.nearest(&q, &y, &q), full.nearest(&q, &[], &q));
        }
    }

    /// The reference values: the median scaled step is the median per-frame change, the
    /// sets hold every frame.
    #[test]
    fn reference_values_are_those_of_the_frames() {
        let t = training();
        assert_eq!(t.raw.z.len(), 60 * 3);
        assert_eq!(t.projected.mesh.len(), 60 * 12);
        // Per frame: 1/30 along c0 (or c1) plus the wobble's change.
        assert!(t.step > 1.0 / 30.0 && t.step < 1.6 / 30.0, "{}", t.step);
        let err = Training::measure(&rig(), &labeled(), vec![1.0; 3], &maps(), 100).unwrap_err().to_string();
        assert!(err.contains("--mesh-reference-limit"), "{err}");
        let err = Training::measure(&rig(), &labeled(), vec![1.0; 3], &maps()[..1], usize::MAX).unwrap_err();
        assert!(err.to_string().contains("no PCA model for label `b`"), "{err}");
    }
}
