//! The animation database: rows of scaled controls $z_t \in \mathbb R^C$ with a label and a
//! segment per frame, and [`FrameSet`], the bitset of frames a search may return.
//!
//! A **segment** is a maximal run of consecutive frames sharing a segment id (one take or
//! one labeled clip). Frame $t+1$ follows $t$ in playback only inside a segment; the last
//! frame of a segment has no next frame.
//!
//! **A label's window.** A jump into label $L$ plays on from the frame jumped to, so a
//! method that wants $w$ frames of continuation after that frame (motion matching's
//! feature horizon, the crossfade's blend) can only be served by a frame with $w$ frames
//! after it in its segment. A label whose segments are all shorter gets the longest window
//! they allow instead: $w_L = \min(w,\ r_L)$ frames, with $r_L$ the label's **longest
//! continuation** $\max_{t:\,\ell_t = L}(\text{segment\_end}(t) - t)$ (its longest segment's
//! length minus 1), and none at all when $r_L = 0$ (only one-frame segments: no frame has a
//! next one to play) — [`Database::label_window`].

use std::collections::BTreeMap;

use crate::error::{check_finite, check_len, MatchError, Result};

/// Training frames in scaled control space with their labels, segments and frame rate.
#[derive(Debug, Clone)]
pub struct Database {
    z: Vec<f64>,
    dim: usize,
    labels: Vec<u32>,
    /// First and last frame of each frame's segment.
    bounds: Vec<(usize, usize)>,
    /// Per label present, its longest continuation $r_L$ (frames).
    reach: BTreeMap<u32, usize>,
    fps: f64,
}

impl Database {
    /// Builds and validates a database.
    ///
    /// - `z`: row-major `n × dim` scaled controls (finite).
    /// - `labels`, `segments`: one per frame; a segment id may not reappear after another
    ///   segment (frames of a take are contiguous).
    /// - `fps`: frames per second (finite, positive).
    ///
    /// # Errors
    /// [`MatchError::ZeroDimension`], [`MatchError::EmptyDatabase`],
    /// [`MatchError::Length`], [`MatchError::NonFinite`], [`MatchError::Fps`],
    /// [`MatchError::SegmentNotContiguous`].
    pub fn new(z: Vec<f64>, dim: usize, labels: Vec<u32>, segments: &[u32], fps: f64) -> Result<Self> {
        if dim == 0 {
            return Err(MatchError::ZeroDimension { what: "controls" });
        }
        if !(fps.is_finite() && fps > 0.0) {
            return Err(MatchError::Fps(fps));
        }
        if !z.len().is_multiple_of(dim) {
            return Err(MatchError::Length {
                what: "controls",
                expected: z.len().div_ceil(dim) * dim,
                actual: z.len(),
            });
        }
        let n = z.len() / dim;
        if n == 0 {
            return Err(MatchError::EmptyDatabase);
        }
        check_len("labels", n, labels.len())?;
        check_len("segments", n, segments.len())?;
        check_finite("controls", &z, dim)?;
        let bounds = segment_bounds(segments)?;
        let mut reach = BTreeMap::new();
        for (t, (&label, &(_, end))) in labels.iter().zip(&bounds).enumerate() {
            let r = reach.entry(label).or_insert(0);
            *r = (*r).max(end - t);
        }
        Ok(Self { z, dim, labels, bounds, reach, fps })
    }

    /// Number of frames $n$.
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    /// Always `false`: a database has at least one frame.
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// Control dimension $C$.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Frames per second.
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// Scaled controls $z_t$ of frame `t` (panics if `t >= len()`).
    pub fn row(&self, t: usize) -> &[f64] {
        &self.z[t * self.dim..(t + 1) * self.dim]
    }

    /// All controls, row-major `n × C`.
    pub fn controls(&self) -> &[f64] {
        &self.z
    }

    /// Label of frame `t`.
    pub fn label(&self, t: usize) -> u32 {
        self.labels[t]
    }

    /// Labels of all frames.
    pub fn labels(&self) -> &[u32] {
        &self.labels
    }

    /// The labels that have frames, in increasing order.
    pub fn label_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.reach.keys().copied()
    }

    /// The longest continuation $r_L$ label `label` offers, in frames: the most frames any
    /// of its frames has after it in its own segment, $\max_{t:\,\ell_t = L}
    /// (\text{segment\_end}(t) - t)$ — its longest segment's length minus 1 (for segments of
    /// one label). `None` if no frame has the label.
    pub fn longest_continuation(&self, label: u32) -> Option<usize> {
        self.reach.get(&label).copied()
    }

    /// The window a jump into `label` gets when `window` frames of continuation are wanted:
    /// $w_L = \min(\texttt{window},\ r_L)$ frames ([`Database::longest_continuation`]) —
    /// `window` itself when some frame of the label has that much continuation, shorter
    /// when all its segments are shorter. `None` when the label has no frame with a next
    /// frame (no frame, or only one-frame segments): nothing can be played after a jump.
    pub fn label_window(&self, label: u32, window: usize) -> Option<usize> {
        self.longest_continuation(label).filter(|&r| r >= 1).map(|r| window.min(r))
    }

    /// First frame of `t`'s segment.
    pub fn segment_start(&self, t: usize) -> usize {
        self.bounds[t].0
    }

    /// Last frame of `t`'s segment.
    pub fn segment_end(&self, t: usize) -> usize {
        self.bounds[t].1
    }

    /// Whether frame `t + 1` follows `t` (same segment).
    pub fn has_next(&self, t: usize) -> bool {
        t < self.bounds[t].1
    }

    /// The frame pair $(a, b)$ whose difference $(x_b - x_a)\cdot\text{fps}$ is the
    /// velocity at `t`: backward $(t-1, t)$, forward $(t, t+1)$ at a segment's first frame,
    /// `None` for a one-frame segment (velocity 0).
    pub(crate) fn difference_pair(&self, t: usize) -> Option<(usize, usize)> {
        let (s0, s1) = self.bounds[t];
        if t > s0 {
            Some((t - 1, t))
        } else if t < s1 {
            Some((t, t + 1))
        } else {
            None
        }
    }

    /// Control velocity $\dot z_t$ in scaled units per second, written into `out`
    /// (length $C$): backward difference, forward at a segment start, 0 for a one-frame
    /// segment. The same stencil as the velocity feature.
    pub fn velocity_into(&self, t: usize, out: &mut [f64]) {
        match self.difference_pair(t) {
            Some((a, b)) => {
                for ((o, xa), xb) in out.iter_mut().zip(self.row(a)).zip(self.row(b)) {
                    *o = (xb - xa) * self.fps;
                }
            }
            None => out.fill(0.0),
        }
    }

    /// Checks `t < len()`.
    pub(crate) fn check_frame(&self, t: usize) -> Result<()> {
        if t < self.len() {
            Ok(())
        } else {
            Err(MatchError::FrameOutOfRange { frame: t, n: self.len() })
        }
    }
}

/// Per frame, the first and last frame of its segment; rejects ids that reappear.
fn segment_bounds(segments: &[u32]) -> Result<Vec<(usize, usize)>> {
    let mut seen = std::collections::HashSet::new();
    let mut bounds = Vec::with_capacity(segments.len());
    let mut start = 0;
    for t in 1..=segments.len() {
        if t == segments.len() || segments[t] != segments[start] {
            if !seen.insert(segments[start]) {
                return Err(MatchError::SegmentNotContiguous { frame: start, segment: segments[start] });
            }
            bounds.extend(std::iter::repeat_n((start, t - 1), t - start));
            start = t;
        }
    }
    Ok(bounds)
}

/// A set of frames of one database, as a bitset (bit $t \bmod 64$ of word $\lfloor t/64
/// \rfloor$). Word-aligned so the search's 64-frame blocks are single words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameSet {
    n: usize,
    words: Vec<u64>,
}

impl FrameSet {
    /// The empty set over `n` frames.
    pub fn empty(n: usize) -> Self {
        Self { n, words: vec![0; n.div_ceil(64)] }
    }

    /// Every frame of `n`.
    pub fn all(n: usize) -> Self {
        let mut s = Self::empty(n);
        for t in 0..n {
            s.insert(t);
        }
        s
    }

    /// The given frames.
    ///
    /// # Errors
    /// [`MatchError::FrameOutOfRange`] for a frame `>= n`.
    pub fn from_frames(n: usize, frames: impl IntoIterator<Item = usize>) -> Result<Self> {
        let mut s = Self::empty(n);
        for t in frames {
            if t >= n {
                return Err(MatchError::FrameOutOfRange { frame: t, n });
            }
            s.insert(t);
        }
        Ok(s)
    }

    /// The frames of `db` with label `label`.
    pub fn with_label(db: &Database, label: u32) -> Self {
        Self::from_predicate(db.len(), |t| db.label(t) == label)
    }

    /// The frames `t < n` with `keep(t)`.
    pub fn from_predicate(n: usize, mut keep: impl FnMut(usize) -> bool) -> Self {
        let mut s = Self::empty(n);
        for t in 0..n {
            if keep(t) {
                s.insert(t);
            }
        }
        s
    }

    /// Adds frame `t` (panics if `t >= universe()`).
    pub fn insert(&mut self, t: usize) {
        assert!(t < self.n, "frame {t} outside a set of {} frames", self.n);
        self.words[t / 64] |= 1 << (t % 64);
    }

    /// Whether `t` is in the set.
    pub fn contains(&self, t: usize) -> bool {
        t < self.n && self.words[t / 64] >> (t % 64) & 1 == 1
    }

    /// Number of frames in the set.
    pub fn len(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.words.iter().all(|&w| w == 0)
    }

    /// Number of frames of the database this set belongs to.
    pub fn universe(&self) -> usize {
        self.n
    }

    /// `self ∩ other` (same universe).
    pub fn intersection(&self, other: &Self) -> Self {
        Self { n: self.n, words: self.words.iter().zip(&other.words).map(|(a, b)| a & b).collect() }
    }

    /// The frames in increasing order.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(w, &word)| {
            let mut bits = word;
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    w * 64 + i
                })
            })
        })
    }

    /// The 64-frame words.
    pub(crate) fn words(&self) -> &[u64] {
        &self.words
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_and_bad_input() {
        let db = Database::new(vec![0.0; 10], 2, vec![0, 0, 1, 1, 1], &[7, 7, 3, 3, 3], 24.0).unwrap();
        assert_eq!((db.segment_start(3), db.segment_end(3)), (2, 4));
        assert!(db.has_next(0) && !db.has_next(1) && !db.has_next(4));
        let err = Database::new(vec![0.0; 6], 2, vec![0; 3], &[1, 2, 1], 24.0);
        assert!(matches!(err, Err(MatchError::SegmentNotContiguous { frame: 2, segment: 1 })));
        assert!(matches!(Database::new(vec![], 2, vec![], &[], 24.0), Err(MatchError::EmptyDatabase)));
        assert!(matches!(
            Database::new(vec![0.0; 5], 2, vec![0; 2], &[0; 2], 24.0),
            Err(MatchError::Length { what: "controls", .. })
        ));
        assert!(matches!(
            Database::new(vec![0.0; 4], 2, vec![0; 3], &[0; 2], 24.0),
            Err(MatchError::Length { what: "labels", .. })
        ));
        let mut z = vec![0.0; 4];
        z[3] = f64::NAN;
        assert!(matches!(
            Database::new(z, 2, vec![0; 2], &[0; 2], 24.0),
            Err(MatchError::NonFinite { frame: 1, column: 1, .. })
        ));
        assert!(matches!(Database::new(vec![0.0; 4], 2, vec![0; 2], &[0; 2], 0.0), Err(MatchError::Fps(_))));
        assert!(matches!(
            Database::new(vec![0.0; 4], 0, vec![0; 2], &[0; 2], 24.0),
            Err(MatchError::ZeroDimension { .. })
        ));
    }

    /// Label 0: segments of 5 and 3 frames; label 1: one-frame segments; label 2: one
    /// segment holding a label-2 frame, then two label-3 frames.
    #[test]
    fn longest_continuation_and_label_window() {
        let labels = vec![0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 2, 3, 3];
        let segments = [0, 0, 0, 0, 0, 1, 1, 1, 2, 3, 4, 4, 4];
        let db = Database::new(vec![0.0; 13], 1, labels, &segments, 24.0).unwrap();
        assert_eq!(db.label_ids().collect::<Vec<_>>(), [0, 1, 2, 3]);
        assert_eq!([0, 1, 2, 3, 4].map(|l| db.longest_continuation(l)), [Some(4), Some(0), Some(2), Some(1), None]);
        assert_eq!(db.label_window(0, 12), Some(4));
        assert_eq!(db.label_window(0, 3), Some(3));
        assert_eq!(db.label_window(0, 0), Some(0));
        assert_eq!(db.label_window(2, 12), Some(2));
        assert_eq!((db.label_window(1, 12), db.label_window(4, 12)), (None, None));
    }

    #[test]
    fn frame_set_round_trips() {
        let frames = [0, 5, 63, 64, 65, 129];
        let s = FrameSet::from_frames(130, frames).unwrap();
        assert_eq!(s.iter().collect::<Vec<_>>(), frames);
        assert_eq!(s.len(), 6);
        assert!(s.contains(64) && !s.contains(1) && !s.contains(500));
        assert!(FrameSet::from_frames(3, [3]).is_err());
        assert_eq!(FrameSet::all(70).len(), 70);
    }
}
