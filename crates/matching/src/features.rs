//! Matching features per database frame and their group normalisation
//! (method.md §7.1, §7.5).
//!
//! The caller projects each frame's scaled controls to $q$ low-dimensional coordinates
//! $y_t \in \mathbb R^q$ (the top PCA scores; any projection works). The raw feature vector of
//! frame $t$ in segment $[s_0, s_1]$ is the concatenation of groups
//!
//! - **current**: $y_t$ (PCA units);
//! - **future** $o$, one group per offset $o \in$ [`FeatureParams::offsets`] (frames):
//!   $y_{\min(t+o,\,s_1)}$ — the continuation's pose $o$ frames ahead, clamped at the
//!   segment end as the reference clamps its trajectory (`database_trajectory_index_clamp`);
//! - **velocity**: $(y_t - y_{t-1})\cdot\text{fps}$ (PCA units per second); the forward
//!   difference $(y_{t+1}-y_t)\cdot\text{fps}$ at a segment's first frame, 0 in a one-frame
//!   segment.
//!
//! A face has no root trajectory, so the future groups take the role of Clavet's
//! trajectory: they describe where the motion is going.
//!
//! **Normalisation** (Holden's `normalize_feature`): over all $n$ frames, per dimension $j$
//! the mean $\mu_j$ and population standard deviation $\sigma_j$; per group $g$ the scale
//! $s_g = \big(\tfrac1{|g|}\sum_{j\in g}\sigma_j\big)/w_g$ with weight $w_g$. The normalised
//! feature is $\hat f_j = (f_j - \mu_j)/s_{g(j)}$, so a group's share of the cost grows as
//! $w_g^2$. A group constant over the database ($\sum\sigma_j = 0$) gets $s_g = 1/w_g$.
//!
//! **Searchable frames**: a frame can be jumped to only if its whole future lies in its
//! segment, $t + c \le s_1$ with the **continuation** $c = \max(o_{\max}, 1)$ frames (the
//! reference's `ignore_range_end`; at least one frame so playback can continue after the
//! jump). A label $L$ none of whose frames has $c$ frames left in its segment (all its
//! segments hold at most $c$ frames) is searched with the longest continuation they allow
//! instead, $c_L = \min(c,\ r_L)$ frames with $r_L$ the label's longest segment's length
//! minus 1 ([`Database::label_window`]): its searchable frames are those with
//! $t + c_L \le s_1$. The features need no change for it — the future groups are already
//! clamped at the segment end, $y_{\min(t+o,\,s_1)}$, so this is the reference's own
//! treatment of segment ends applied per label. Every label with a frame of full
//! continuation keeps $c_L = c$ and exactly the set above; a label of one-frame segments
//! ($r_L = 0$) has no searchable frame ([`FeatureDb::continuation_of`] is `None`).

use std::collections::BTreeMap;

use crate::database::{Database, FrameSet};
use crate::error::{check_finite, check_len, MatchError, Result};
use crate::search::Blocks;

/// Which part of the motion a feature group describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GroupKind {
    /// $y_t$.
    Current,
    /// $y_{t+o}$ (clamped to the segment end).
    Future {
        /// Offset $o$ in frames.
        offset: usize,
    },
    /// $\dot y_t$ in units per second.
    Velocity,
}

/// One feature group: its columns `start..start + len`, weight and scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureGroup {
    /// What the group describes.
    pub kind: GroupKind,
    /// First column.
    pub start: usize,
    /// Number of columns ($q$).
    pub len: usize,
    /// Weight $w_g$.
    pub weight: f64,
    /// Scale $s_g$ (mean std of the group over the database, divided by $w_g$).
    pub scale: f64,
}

/// How to build features. Defaults: offsets 4, 8, 12 frames (≈ 0.17, 0.33, 0.5 s at
/// 24 fps), every weight 1.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureParams {
    /// Future offsets in frames, each ≥ 1.
    pub offsets: Vec<usize>,
    /// Weight of the current-pose group.
    pub current_weight: f64,
    /// Weight of each future group.
    pub future_weight: f64,
    /// Weight of the velocity group.
    pub velocity_weight: f64,
}

impl Default for FeatureParams {
    fn default() -> Self {
        Self { offsets: vec![4, 8, 12], current_weight: 1.0, future_weight: 1.0, velocity_weight: 1.0 }
    }
}

impl FeatureParams {
    fn check(&self) -> Result<()> {
        if self.offsets.contains(&0) {
            return Err(MatchError::Param {
                name: "offsets",
                reason: "every future offset must be at least 1 frame".into(),
            });
        }
        for (name, w) in [
            ("current_weight", self.current_weight),
            ("future_weight", self.future_weight),
            ("velocity_weight", self.velocity_weight),
        ] {
            if !(w.is_finite() && w > 0.0) {
                return Err(MatchError::Param {
                    name,
                    reason: format!("weights must be finite and positive, got {w}"),
                });
            }
        }
        Ok(())
    }

    /// The groups in column order, scales not yet set.
    fn groups(&self, q: usize) -> Vec<FeatureGroup> {
        let kinds = std::iter::once((GroupKind::Current, self.current_weight))
            .chain(self.offsets.iter().map(|&offset| (GroupKind::Future { offset }, self.future_weight)))
            .chain(std::iter::once((GroupKind::Velocity, self.velocity_weight)));
        kinds
            .enumerate()
            .map(|(g, (kind, weight))| FeatureGroup { kind, start: g * q, len: q, weight, scale: 1.0 })
            .collect()
    }
}

/// Normalised features of every database frame, the searchable set and the search's
/// bounding boxes. Built once per database; searched many times ([`FeatureDb::search`]).
#[derive(Debug, Clone)]
pub struct FeatureDb {
    pub(crate) n: usize,
    pub(crate) dim: usize,
    groups: Vec<FeatureGroup>,
    mean: Vec<f64>,
    /// Per column, the scale of its group.
    col_scale: Vec<f64>,
    /// Row-major `n × dim`, normalised.
    pub(crate) features: Vec<f64>,
    pub(crate) searchable: FrameSet,
    continuation: usize,
    /// Per label with a searchable frame, its continuation $c_L \in 1..=c$ (frames).
    label_continuation: BTreeMap<u32, usize>,
    pub(crate) blocks: Blocks,
}

impl FeatureDb {
    /// Builds features from per-frame coordinates `y` (row-major `n × q`, e.g. the top $q$
    /// PCA scores of each row of `db`).
    ///
    /// # Errors
    /// [`MatchError::ZeroDimension`] for `q == 0`, [`MatchError::Length`] if `y` is not
    /// `n × q`, [`MatchError::NonFinite`], [`MatchError::Param`] for a zero offset or a
    /// weight that is not finite and positive.
    pub fn build(db: &Database, y: &[f64], q: usize, params: &FeatureParams) -> Result<Self> {
        params.check()?;
        if q == 0 {
            return Err(MatchError::ZeroDimension { what: "coordinates" });
        }
        let n = db.len();
        check_len("coordinates", n * q, y.len())?;
        check_finite("coordinates", y, q)?;
        let mut groups = params.groups(q);
        let dim = groups.len() * q;
        let mut features = vec![0.0; n * dim];
        for (t, row) in features.chunks_exact_mut(dim).enumerate() {
            raw_features_into(db, y, q, &groups, t, row);
        }
        let (mean, std) = mean_std(&features, dim);
        let mut col_scale = vec![0.0; dim];
        for g in &mut groups {
            let cols = g.start..g.start + g.len;
            let mean_std = std[cols.clone()].iter().sum::<f64>() / g.len as f64;
            g.scale = if mean_std > 0.0 { mean_std } else { 1.0 } / g.weight;
            col_scale[cols].fill(g.scale);
        }
        for row in features.chunks_exact_mut(dim) {
            normalize_in_place(row, &mean, &col_scale);
        }
        let continuation = params.offsets.iter().copied().max().unwrap_or(0).max(1);
        let label_continuation: BTreeMap<u32, usize> =
            db.label_ids().filter_map(|l| db.label_window(l, continuation).map(|c| (l, c))).collect();
        let searchable = FrameSet::from_predicate(n, |t| {
            label_continuation.get(&db.label(t)).is_some_and(|&c| t + c <= db.segment_end(t))
        });
        let blocks = Blocks::build(&features, dim, &searchable);
        Ok(Self { n, dim, groups, mean, col_scale, features, searchable, continuation, label_continuation, blocks })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always `false` (a database has frames).
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Feature dimension $d = q\,(2 + \#\text{offsets})$.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The groups in column order, with their scales.
    pub fn groups(&self) -> &[FeatureGroup] {
        &self.groups
    }

    /// Per-column mean $\mu_j$ of the raw features.
    pub fn mean(&self) -> &[f64] {
        &self.mean
    }

    /// Normalised features $\hat f_t$ of frame `t` (panics if `t >= len()`).
    pub fn features(&self, t: usize) -> &[f64] {
        &self.features[t * self.dim..(t + 1) * self.dim]
    }

    /// Frames a search may return: those of each label $L$ with $c_L$
    /// ([`FeatureDb::continuation_of`]) frames left in their segment — `continuation()`
    /// frames for every label that has a frame with that much.
    pub fn searchable(&self) -> &FrameSet {
        &self.searchable
    }

    /// The full continuation $c = \max(o_{\max}, 1)$ in frames: what a searchable frame of
    /// a label with long enough segments has left in its segment.
    pub fn continuation(&self) -> usize {
        self.continuation
    }

    /// The continuation label `label` is searched with, in frames:
    /// $c_L = \min(c,\ r_L)$ (module docs) — [`FeatureDb::continuation`] unless every segment
    /// of the label is too short for it, then its longest segment's length minus 1. `None`
    /// if the label has no searchable frame (no frame, or only one-frame segments).
    pub fn continuation_of(&self, label: u32) -> Option<usize> {
        self.label_continuation.get(&label).copied()
    }

    /// Normalises a raw feature vector (laid out as [`FeatureDb::groups`]) into a query.
    ///
    /// # Errors
    /// [`MatchError::Length`], [`MatchError::NonFinite`].
    pub fn normalize(&self, raw: &[f64]) -> Result<Vec<f64>> {
        check_len("query", self.dim, raw.len())?;
        check_finite("query", raw, self.dim)?;
        let mut out = raw.to_vec();
        normalize_in_place(&mut out, &self.mean, &self.col_scale);
        Ok(out)
    }

    /// Searchable frames of `label` in `db`.
    ///
    /// # Errors
    /// [`MatchError::Mismatch`] if `db` is not the database these features were built
    /// from (frame counts differ).
    pub fn searchable_with_label(&self, db: &Database, label: u32) -> Result<FrameSet> {
        self.check_db(db)?;
        Ok(FrameSet::with_label(db, label).intersection(&self.searchable))
    }

    pub(crate) fn check_db(&self, db: &Database) -> Result<()> {
        if db.len() == self.n {
            Ok(())
        } else {
            Err(MatchError::Mismatch { what: "features", expected: db.len(), actual: self.n })
        }
    }
}

/// Raw (unnormalised) features of frame `t` into `row`.
fn raw_features_into(db: &Database, y: &[f64], q: usize, groups: &[FeatureGroup], t: usize, row: &mut [f64]) {
    let at = |s: usize| &y[s * q..(s + 1) * q];
    for g in groups {
        let out = &mut row[g.start..g.start + g.len];
        match g.kind {
            GroupKind::Current => out.copy_from_slice(at(t)),
            GroupKind::Future { offset } => {
                out.copy_from_slice(at((t + offset).min(db.segment_end(t))));
            }
            GroupKind::Velocity => match db.difference_pair(t) {
                Some((a, b)) => {
                    for ((o, ya), yb) in out.iter_mut().zip(at(a)).zip(at(b)) {
                        *o = (yb - ya) * db.fps();
                    }
                }
                None => out.fill(0.0),
            },
        }
    }
}

/// Per-column mean and population standard deviation of a row-major matrix.
fn mean_std(x: &[f64], dim: usize) -> (Vec<f64>, Vec<f64>) {
    let n = (x.len() / dim) as f64;
    let mut mean = vec![0.0; dim];
    for row in x.chunks_exact(dim) {
        for (m, v) in mean.iter_mut().zip(row) {
            *m += v;
        }
    }
    mean.iter_mut().for_each(|m| *m /= n);
    let mut var = vec![0.0; dim];
    for row in x.chunks_exact(dim) {
        for ((s, v), m) in var.iter_mut().zip(row).zip(&mean) {
            *s += (v - m) * (v - m);
        }
    }
    let std = var.iter().map(|s| (s / n).sqrt()).collect();
    (mean, std)
}

fn normalize_in_place(row: &mut [f64], mean: &[f64], scale: &[f64]) {
    for ((v, m), s) in row.iter_mut().zip(mean).zip(scale) {
        *v = (*v - m) / s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    /// Scales equal hand-computed values on a tiny database: one segment of 4 frames,
    /// q = 2, one future offset of 1 frame (groups current, future+1, velocity).
    #[test]
    fn group_scales_match_hand_computation() {
        let db = Database::new(vec![0.0; 4], 1, vec![0; 4], &[0; 4], 2.0).unwrap();
        // y rows: (0, 0), (1, 10), (3, 10), (6, 40)
        let y = [0.0, 0.0, 1.0, 10.0, 3.0, 10.0, 6.0, 40.0];
        let params = FeatureParams { offsets: vec![1], current_weight: 1.0, future_weight: 2.0, velocity_weight: 0.5 };
        let f = FeatureDb::build(&db, &y, 2, &params).unwrap();
        // current column 0: 0,1,3,6 → mean 2.5, var (6.25+2.25+0.25+12.25)/4 = 5.25
        // current column 1: 0,10,10,40 → mean 15, var (225+25+25+625)/4 = 225
        let s_cur = (5.25f64.sqrt() + 15.0) / 2.0;
        // future(+1, clamped): rows 1,2,3,3 → col0 1,3,6,6 mean 4 var (9+1+4+4)/4=4.5;
        // col1 10,10,40,40 mean 25 var 225
        let s_fut = (4.5f64.sqrt() + 15.0) / 2.0 / 2.0;
        // velocity (fps 2): t0 forward (1,10)*2=(2,20); t1 (2,20); t2 (4,0); t3 (6,60)
        // col0 2,2,4,6 mean 3.5 var (2.25+2.25+0.25+6.25)/4 = 2.75
        // col1 20,20,0,60 mean 25 var (25+25+625+1225)/4 = 475
        let s_vel = (2.75f64.sqrt() + 475f64.sqrt()) / 2.0 / 0.5;
        let g = f.groups();
        assert_eq!(g.len(), 3);
        assert_eq!(g[1].kind, GroupKind::Future { offset: 1 });
        assert_abs_diff_eq!(g[0].scale, s_cur, epsilon = 1e-12);
        assert_abs_diff_eq!(g[1].scale, s_fut, epsilon = 1e-12);
        assert_abs_diff_eq!(g[2].scale, s_vel, epsilon = 1e-12);
        assert_abs_diff_eq!(f.mean()[5], 25.0, epsilon = 1e-12);
        // frame 3's normalised velocity column 1: (60 - 25) / s_vel
        assert_abs_diff_eq!(f.features(3)[5], 35.0 / s_vel, epsilon = 1e-12);
        // offsets 1: frames 0..=2 searchable, the last is not.
        assert_eq!(f.searchable().iter().collect::<Vec<_>>(), [0, 1, 2]);
    }

    /// Label 0: two 40-frame segments; label 1: 6-frame segments and a 4-frame one;
    /// label 2: one-frame segments. Label 1 has no frame with 12 frames of continuation, so
    /// it is searched with $c_1 = 6 - 1 = 5$: exactly the first frame of each 6-frame
    /// segment (the 4-frame one has none). Label 0 keeps the full rule $t + 12 \le s_1$.
    #[test]
    fn a_short_label_is_searched_with_its_longest_continuation() {
        let lens = [(0, 40), (1, 6), (0, 40), (1, 4), (2, 1), (1, 6), (2, 1), (2, 1)];
        let (db, y) = segments_db(&lens);
        let f = FeatureDb::build(&db, &y, 2, &FeatureParams::default()).unwrap();
        assert_eq!(f.continuation(), 12);
        assert_eq!([0, 1, 2, 3].map(|l| f.continuation_of(l)), [Some(12), Some(5), None, None]);
        let full = FrameSet::from_predicate(db.len(), |t| db.label(t) == 0 && t + 12 <= db.segment_end(t));
        assert_eq!(f.searchable_with_label(&db, 0).unwrap(), full);
        assert_eq!(full.len(), 2 * 28);
        // Segment starts: 0, 40, 46, 86, 90, 91, 97, 98.
        assert_eq!(f.searchable_with_label(&db, 1).unwrap().iter().collect::<Vec<_>>(), [40, 91]);
        assert!(f.searchable_with_label(&db, 2).unwrap().is_empty());
        assert_eq!(f.searchable().len(), 2 * 28 + 2);
    }

    /// A database of segments `(label, length)` in order, one control, with y (q = 2) a
    /// deterministic wiggle.
    fn segments_db(lens: &[(u32, usize)]) -> (Database, Vec<f64>) {
        let labels: Vec<u32> = lens.iter().flat_map(|&(l, n)| std::iter::repeat_n(l, n)).collect();
        let segments: Vec<u32> =
            (0..lens.len() as u32).flat_map(|s| std::iter::repeat_n(s, lens[s as usize].1)).collect();
        let n = labels.len();
        let y: Vec<f64> = (0..2 * n).map(|i| (i as f64 * 0.37).sin()).collect();
        (Database::new(vec![0.0; n], 1, labels, &segments, 24.0).unwrap(), y)
    }

    #[test]
    fn bad_feature_input_is_an_error() {
        let db = Database::new(vec![0.0; 4], 1, vec![0; 4], &[0; 4], 24.0).unwrap();
        let p = FeatureParams::default();
        assert!(matches!(FeatureDb::build(&db, &[0.0; 7], 2, &p), Err(MatchError::Length { what: "coordinates", .. })));
        assert!(matches!(FeatureDb::build(&db, &[], 0, &p), Err(MatchError::ZeroDimension { .. })));
        let mut y = [0.0; 8];
        y[5] = f64::INFINITY;
        assert!(matches!(FeatureDb::build(&db, &y, 2, &p), Err(MatchError::NonFinite { frame: 2, column: 1, .. })));
        let bad = FeatureParams { offsets: vec![0], ..p.clone() };
        assert!(matches!(FeatureDb::build(&db, &[0.0; 8], 2, &bad), Err(MatchError::Param { .. })));
        let bad = FeatureParams { velocity_weight: f64::NAN, ..p.clone() };
        assert!(matches!(FeatureDb::build(&db, &[0.0; 8], 2, &bad), Err(MatchError::Param { .. })));
        let f = FeatureDb::build(&db, &[0.0; 8], 2, &p).unwrap();
        assert!(matches!(f.normalize(&[0.0; 3]), Err(MatchError::Length { .. })));
        let mut raw = vec![0.0; f.dim()];
        raw[0] = f64::NAN;
        assert!(matches!(f.normalize(&raw), Err(MatchError::NonFinite { .. })));
        let other = Database::new(vec![0.0; 5], 1, vec![0; 5], &[0; 5], 24.0).unwrap();
        assert!(matches!(f.searchable_with_label(&other, 0), Err(MatchError::Mismatch { .. })));
    }
}
