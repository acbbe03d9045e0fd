//! The crossfade baseline — the floor every transition method must beat.
//!
//! On a request while start frame $s$ is shown, pick the target frame $j$ nearest the
//! current pose in scaled control space, $j = \arg\min_t \lVert z_t - z_s\rVert^2$ over the
//! target's frames with $k$ frames of continuation in their segment
//! ($t + \max(k,1) \le$ segment end), lowest index on ties. The blend is $k =$
//! `blend_frames` frames, or, for a target $L$ whose segments are all too short for it,
//! the longest they allow: $k_L = \min(\texttt{blend\_frames},\ r_L)$ with $r_L$ the label's
//! longest segment's length minus 1 ([`crossfade_blend`], [`Database::label_window`]); only
//! a label of one-frame segments cannot be crossfaded into. Then for $p = 0,\dots,k-1$
//! output
//! $$\alpha(p)\,z^A_p + (1-\alpha(p))\,z_{j+1+p},$$
//! with $\alpha$ the Motion Graphs ease ([`reprise_transition_graph::blend_weight`]: $\alpha(-1) =
//! 1$, $\alpha(k-1) = 0$, zero slope at both ends) so both baselines blend alike, and
//! $z^A_p = z_{\min(s+1+p,\ \text{segment\_end}(s))}$: the source **keeps playing** while it
//! has frames and holds its last frame after. From $p = k$ on, $B$ plays on ($z_{j+1+p}$).
//! When $B$'s segment ends the same rule chains a new crossfade from its last (held)
//! frame. $k = 0$ is a hard cut.

use crate::database::{Database, FrameSet};
use crate::error::{check_finite, check_len, MatchError, Result};
use crate::playback::Playback;
use crate::search::Match;
use reprise_transition_graph::blend_weight;

/// The blend a crossfade into `label` uses when asked for `blend_frames`, in frames:
/// $k_L = \min(\texttt{blend\_frames},\ r_L)$ ([`Database::label_window`]) — `blend_frames`
/// unless every segment of the label is too short for it. `None` if the label has no frame
/// with a next frame (no frame, or only one-frame segments).
pub fn crossfade_blend(db: &Database, label: u32, blend_frames: usize) -> Option<usize> {
    db.label_window(label, blend_frames)
}

/// The frames of `label` a crossfade asked for `blend_frames` may start from: those with
/// $\max(k_L, 1)$ frames of continuation in their segment, $k_L$ the blend it uses
/// ([`crossfade_blend`]); empty if there is none.
pub fn crossfade_candidates(db: &Database, label: u32, blend_frames: usize) -> FrameSet {
    match crossfade_blend(db, label, blend_frames) {
        Some(k) => {
            let need = k.max(1);
            FrameSet::from_predicate(db.len(), |t| db.label(t) == label && t + need <= db.segment_end(t))
        }
        None => FrameSet::empty(db.len()),
    }
}

/// The candidate nearest `pose` in squared Euclidean distance on $z$ (lowest index on
/// ties), `None` if `candidates` is empty.
///
/// # Errors
/// [`MatchError::Length`] / [`MatchError::NonFinite`] for a bad pose,
/// [`MatchError::Mismatch`] if `candidates` belongs to another database.
pub fn nearest_pose(db: &Database, pose: &[f64], candidates: &FrameSet) -> Result<Option<Match>> {
    check_len("pose", db.dim(), pose.len())?;
    check_finite("pose", pose, db.dim())?;
    if candidates.universe() != db.len() {
        return Err(MatchError::Mismatch {
            what: "candidate frames",
            expected: db.len(),
            actual: candidates.universe(),
        });
    }
    let mut best: Option<Match> = None;
    for t in candidates.iter() {
        let cost: f64 = db.row(t).iter().zip(pose).map(|(a, b)| (a - b) * (a - b)).sum();
        if best.is_none_or(|m| cost < m.cost) {
            best = Some(Match { frame: t, cost });
        }
    }
    Ok(best)
}

/// Crossfades from `start` into label `target` over `blend_frames` — over
/// [`crossfade_blend`] frames if the target's segments are all shorter (the blend used is
/// [`Playback::window`]) — producing `frames` output frames (frame 0 follows the request).
///
/// # Errors
/// [`MatchError::FrameOutOfRange`], [`MatchError::NoSearchableFrames`] if `target` has no
/// frame with a next frame in its segment (no frame, or only one-frame segments).
pub fn crossfade(db: &Database, start: usize, target: u32, blend_frames: usize, frames: usize) -> Result<Playback> {
    let mut fade = Crossfader::new(db, start, target, blend_frames)?;
    let mut out = Playback::new(db.dim(), target, fade.blend_frames(), frames);
    let mut row = vec![0.0; db.dim()];
    for _ in 0..frames {
        let f = fade.step(&mut row)?;
        out.push(&row, f.frame, f.label, f.switch, f.source_weight);
    }
    Ok(out)
}

/// A crossfade played one frame at a time: [`crossfade`]'s rule, and a live character's
/// (which may be sent to another label, or into a take, whenever no blend is under way).
#[derive(Debug, Clone)]
pub struct Crossfader<'a> {
    db: &'a Database,
    target: u32,
    blend_frames: usize,
    candidates: FrameSet,
    /// The frame being left.
    a: usize,
    /// The frame of the target playing.
    b: usize,
    /// Frames into the blend.
    p: usize,
    /// Whether the blend is one the rule chained at a segment's end (not one asked for).
    chained: bool,
}

/// One frame of a [`Crossfader`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FadeFrame {
    /// The database frame playing (the destination's, during a blend).
    pub frame: usize,
    /// Its label.
    pub label: u32,
    /// Whether a crossfade started at this frame.
    pub switch: bool,
    /// Weight still on the frame being left, $\alpha(p)$ (0 after the blend).
    pub source_weight: f64,
}

impl<'a> Crossfader<'a> {
    /// A crossfade from `start` (shown) into label `target`.
    ///
    /// # Errors
    /// As [`crossfade`].
    pub fn new(db: &'a Database, start: usize, target: u32, blend_frames: usize) -> Result<Self> {
        db.check_frame(start)?;
        let mut fade = Self {
            db,
            target,
            blend_frames: 0,
            candidates: FrameSet::empty(db.len()),
            a: start,
            b: start,
            p: 0,
            chained: false,
        };
        fade.retarget(target, blend_frames)?;
        Ok(fade)
    }

    /// A crossfader playing on from `start` (shown) in its take, as if a crossfade into
    /// label `target` (`start`'s own) had just ended.
    ///
    /// # Errors
    /// As [`crossfade`]; [`MatchError::FrameOutOfRange`] if `start` is its take's last frame.
    pub fn playing(db: &'a Database, start: usize, target: u32, blend_frames: usize) -> Result<Self> {
        let mut fade = Self::new(db, start, target, blend_frames)?;
        if !db.has_next(start) {
            return Err(MatchError::FrameOutOfRange { frame: start + 1, n: db.segment_end(start) });
        }
        (fade.a, fade.b, fade.p) = (start, start + 1, fade.blend_frames);
        Ok(fade)
    }

    /// The blend used, frames ([`crossfade_blend`]).
    pub fn blend_frames(&self) -> usize {
        self.blend_frames
    }

    /// The label it plays or blends into.
    pub fn target(&self) -> u32 {
        self.target
    }

    /// Whether a blend is under way (the next frame is one of its frames).
    pub fn blending(&self) -> bool {
        self.p < self.blend_frames
    }

    /// Whether a new crossfade may start now without leaving a half-blended pose: no blend
    /// is under way, or one the rule chained at a segment's end is about to begin (the frame
    /// shown last was the segment's last, unblended). A live character that waits for
    /// blends to end must accept this too: a take whose last frame is nearest its own
    /// frame `blend_frames` before the end chains into itself for ever, never between
    /// blends otherwise.
    pub fn interruptible(&self) -> bool {
        !self.blending() || (self.chained && self.p == 0)
    }

    /// A new crossfade, from the frame shown last, into label `target`.
    ///
    /// # Errors
    /// [`MatchError::NoSearchableFrames`] if `target` has no frame with a next frame in its
    /// segment; the crossfade goes on as before.
    pub fn retarget(&mut self, target: u32, blend_frames: usize) -> Result<()> {
        let none = MatchError::NoSearchableFrames { label: target, needed: 1 };
        let blend = crossfade_blend(self.db, target, blend_frames).ok_or(none.clone())?;
        let candidates = crossfade_candidates(self.db, target, blend);
        // Before a chained blend's first frame the segment's held last frame is the one shown.
        let shown = if self.chained && self.p == 0 { self.a } else { self.b };
        let m = nearest_pose(self.db, self.db.row(shown), &candidates)?.ok_or(none)?;
        (self.target, self.blend_frames, self.candidates) = (target, blend, candidates);
        (self.a, self.b, self.p, self.chained) = (shown, m.frame + 1, 0, false);
        Ok(())
    }

    /// A new crossfade, from the frame shown last, into database frame `frame` (a take's
    /// first frame, say); it then plays on as a crossfade into that frame's label.
    ///
    /// # Errors
    /// [`MatchError::FrameOutOfRange`]; as [`Crossfader::retarget`] for its label.
    pub fn fade_to_frame(&mut self, frame: usize, blend_frames: usize) -> Result<()> {
        self.db.check_frame(frame)?;
        self.retarget(self.db.label(frame), blend_frames)?;
        self.b = frame;
        Ok(())
    }

    /// The next frame's scaled controls into `row` (`dim` values).
    ///
    /// # Errors
    /// [`MatchError::NoSearchableFrames`] if a segment end finds no frame to chain into
    /// (it cannot: the candidates were not empty when the target was set).
    pub fn step(&mut self, row: &mut [f64]) -> Result<FadeFrame> {
        let db = self.db;
        let (k, p) = (self.blend_frames, self.p);
        let source_weight = if p < k {
            if db.has_next(self.a) {
                self.a += 1;
            }
            let alpha = blend_weight(p as f64, k);
            for ((o, za), zb) in row.iter_mut().zip(db.row(self.a)).zip(db.row(self.b)) {
                *o = alpha * za + (1.0 - alpha) * zb;
            }
            alpha
        } else {
            row.copy_from_slice(db.row(self.b));
            0.0
        };
        let frame = FadeFrame { frame: self.b, label: db.label(self.b), switch: p == 0, source_weight };
        self.p += 1;
        if db.has_next(self.b) {
            self.b += 1;
        } else {
            // The same rule chains a new crossfade from the held last frame.
            let none = MatchError::NoSearchableFrames { label: self.target, needed: 1 };
            let m = nearest_pose(db, db.row(self.b), &self.candidates)?.ok_or(none)?;
            (self.a, self.b, self.p, self.chained) = (self.b, m.frame + 1, 0, true);
        }
        Ok(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{short_clips, two_sines};
    use approx::assert_abs_diff_eq;

    /// One control. Label 0: frames 0..=5, z = 0..5. Label 1: frames 6..=13,
    /// z = 10, 2.2, 7, 3.1, 9, 9, 8, 3.0. With k = 2 candidates are 6..=11 (frame 13's
    /// 3.0 is nearer to z = 3 but has no continuation).
    fn toy() -> Database {
        let z = vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 10.0, 2.2, 7.0, 3.1, 9.0, 9.0, 8.0, 3.0];
        let labels: Vec<u32> = (0..14).map(|t| u32::from(t >= 6)).collect();
        Database::new(z, 1, labels.clone(), &labels, 24.0).unwrap()
    }

    /// A take whose last frame is nearest its own frame k before the end chains into itself
    /// for ever, blending at every frame; it is interruptible between two such blends, and a
    /// crossfade started there leaves from the held last frame and reaches its label.
    #[test]
    fn a_self_chaining_take_is_interruptible_between_blends() {
        // Label 0: frames 0..=5, z = 0..5. Label 1: frames 6..=13, z = 0..5, 6, 6: the
        // end (6) is nearest frame 11 (5), so each chain plays 12, 13 and chains again.
        let z = vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 6.0];
        let labels: Vec<u32> = (0..14).map(|t| u32::from(t >= 6)).collect();
        let db = Database::new(z, 1, labels.clone(), &labels, 24.0).unwrap();
        let mut f = Crossfader::playing(&db, 7, 1, 2).unwrap();
        let mut row = [0.0];
        let mut interruptible_at = Vec::new();
        for i in 0..20 {
            let out = f.step(&mut row).unwrap();
            if i >= 8 {
                assert!(out.frame >= 12 && f.blending(), "frame {i}: {out:?} loops in a blend");
            }
            if f.interruptible() {
                interruptible_at.push(i);
            }
        }
        assert!(interruptible_at.len() >= 8, "{interruptible_at:?}");
        // From there: a crossfade from the held last frame (z = 6) into label 0's nearest
        // candidate (frame 3, z = 3: 0..=3 have 2 frames left), ½·6 + ½·z₄ = 5 first.
        f.retarget(0, 2).unwrap();
        assert_abs_diff_eq!(f.step(&mut row).unwrap().source_weight, 0.5, epsilon = 1e-12);
        assert_abs_diff_eq!(row[0], 5.0, epsilon = 1e-12);
        let out = f.step(&mut row).unwrap();
        assert_eq!((out.label, row[0]), (0, 5.0));
    }

    /// The nearest candidate is chosen, and the output is the hand-computed blend:
    /// α(0) = 2/8 − 3/4 + 1 = ½ for k = 2, so frame 0 = ½·z₄ + ½·z₁₀ = 6.5, frame 1 = z₁₁
    /// (α(1) = 0), then z₁₂, z₁₃; B's segment ends, and a new crossfade from the held
    /// frame 13 (3.0) picks frame 9 again: ½·3.0 + ½·z₁₀ = 6.
    #[test]
    fn nearest_frame_and_hand_computed_blend() {
        let db = toy();
        let cand = crossfade_candidates(&db, 1, 2);
        assert_eq!(cand.iter().collect::<Vec<_>>(), (6..=11).collect::<Vec<_>>());
        let m = nearest_pose(&db, db.row(3), &cand).unwrap().unwrap();
        assert_eq!(m.frame, 9);
        assert_abs_diff_eq!(m.cost, 0.01, epsilon = 1e-12);
        let out = crossfade(&db, 3, 1, 2, 6).unwrap();
        assert_eq!(out.z, [6.5, 9.0, 8.0, 3.0, 6.0, 9.0]);
        assert_eq!(out.frames, [10, 11, 12, 13, 10, 11]);
        assert_eq!(out.switches, [true, false, false, false, true, false]);
        assert_eq!(out.source_weight, [0.5, 0.0, 0.0, 0.0, 0.5, 0.0]);
        assert_eq!(out.latency, Some(0));
        // k = 0 is a hard cut to the frame after the nearest one.
        assert_eq!(crossfade(&db, 3, 1, 0, 2).unwrap().z, [9.0, 9.0]);
    }

    /// On the sines (label 1 = label 0 + constant in control 2), from frame s = 30 the
    /// nearest label-1 frame is the phase-matched 150; output frame p of a 12-frame blend is
    /// α(p)·z₃₁₊ₚ + (1 − α(p))·z₁₅₁₊ₚ with α written out here; the first output frame is
    /// continuous with the last one before the request.
    #[test]
    fn sine_blend_is_continuous() {
        let (db, _) = two_sines(1.0, 24);
        let (s, k) = (30, 12);
        let out = crossfade(&db, s, 1, k, 20).unwrap();
        assert_eq!(out.frames[0], 151);
        for p in [0, 5, 11] {
            let u = (p as f64 + 1.0) / k as f64;
            let alpha = 2.0 * u.powi(3) - 3.0 * u.powi(2) + 1.0;
            for c in 0..3 {
                let want = alpha * db.row(s + 1 + p)[c] + (1.0 - alpha) * db.row(151 + p)[c];
                assert_abs_diff_eq!(out.row(p)[c], want, epsilon = 1e-12);
            }
        }
        let dist =
            |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt() };
        let step = dist(db.row(s + 1), db.row(s));
        assert!(dist(out.row(0), db.row(s)) < 1.2 * step);
        // Every step of the blend stays small (the gap of 1 is spread over 12 frames).
        assert!((1..20).all(|k| dist(out.row(k), out.row(k - 1)) < 0.25));
    }

    /// Label 1's only segment (frames 6..=13) is 8 frames long: a blend of 8 frames used to
    /// fail; it now blends over the 7 frames the segment allows, from its first frame, the
    /// only one with 7 frames after it (α(p) for k = 7). Asked for 2, it blends over 2.
    #[test]
    fn a_blend_longer_than_the_target_segments_is_shortened_to_them() {
        let db = toy();
        assert_eq!((crossfade_blend(&db, 1, 8), crossfade_blend(&db, 1, 2)), (Some(7), Some(2)));
        assert_eq!(crossfade_candidates(&db, 1, 8).iter().collect::<Vec<_>>(), [6]);
        let out = crossfade(&db, 3, 1, 8, 9).unwrap();
        assert_eq!((out.window, out.latency), (7, Some(0)));
        assert_eq!(out.frames, [7, 8, 9, 10, 11, 12, 13, 7, 8]);
        for p in 0..7 {
            assert_abs_diff_eq!(out.source_weight[p], blend_weight(p as f64, 7), epsilon = 1e-15);
            let want =
                out.source_weight[p] * db.row((4 + p).min(5))[0] + (1.0 - out.source_weight[p]) * db.row(7 + p)[0];
            assert_abs_diff_eq!(out.row(p)[0], want, epsilon = 1e-12);
        }
        assert_eq!(out.source_weight[6], 0.0);
        assert_eq!(crossfade(&db, 3, 1, 2, 5).unwrap().window, 2);
    }

    /// Label 1's only segments are 6 frames long, label 0's one is 120: a 12-frame crossfade
    /// into label 1 (which failed with `NoSearchableFrames`) now blends over 5 frames from a
    /// segment's first frame; into label 0 it is unchanged (12 frames, the full-window
    /// candidates); label 2 has only one-frame segments and still fails.
    #[test]
    fn a_short_label_is_crossfaded_into_over_its_longest_continuation() {
        let (db, _) = short_clips(6, 8);
        assert_eq!(crossfade_blend(&db, 1, 12), Some(5));
        let starts: Vec<usize> = (120..168).step_by(6).collect();
        assert_eq!(crossfade_candidates(&db, 1, 12).iter().collect::<Vec<_>>(), starts);
        let out = crossfade(&db, 10, 1, 12, 30).unwrap();
        assert_eq!((out.window, out.latency), (5, Some(0)));
        assert!(out.labels.iter().all(|&l| l == 1));
        assert_eq!(out.switches.iter().filter(|&&b| b).count(), 6, "a new 5-frame blend per segment");
        assert_eq!(
            out.source_weight[..5].iter().map(|&a| a > 0.0).collect::<Vec<_>>(),
            [true, true, true, true, false]
        );
        let full = FrameSet::from_predicate(db.len(), |t| db.label(t) == 0 && t + 12 <= db.segment_end(t));
        assert_eq!(crossfade_candidates(&db, 0, 12), full);
        assert_eq!(crossfade(&db, 130, 0, 12, 20).unwrap().window, 12);
        assert!(matches!(crossfade(&db, 10, 2, 12, 5), Err(MatchError::NoSearchableFrames { label: 2, needed: 1 })));
        assert!(crossfade_candidates(&db, 2, 12).is_empty());
    }

    /// Regression (a label whose clips are 11 frames, blend 12): the crossfade answered none
    /// of the requests into it; it now blends over 10 frames.
    #[test]
    fn regression_eleven_frame_clips_are_crossfaded_over_ten_frames() {
        let (db, _) = short_clips(11, 5);
        let out = crossfade(&db, 30, 1, 12, 40).unwrap();
        assert_eq!((out.window, out.latency), (10, Some(0)));
        assert!(out.labels.iter().all(|&l| l == 1));
        let weights: Vec<f64> = (0..10).map(|p| blend_weight(p as f64, 10)).collect();
        assert_eq!(out.source_weight[..10], weights[..]);
    }

    #[test]
    fn bad_input_is_an_error() {
        let db = toy();
        let one_frame = Database::new(vec![0.0, 1.0, 2.0], 1, vec![0, 0, 1], &[0, 0, 1], 24.0).unwrap();
        assert!(matches!(
            crossfade(&one_frame, 0, 1, 8, 5),
            Err(MatchError::NoSearchableFrames { label: 1, needed: 1 })
        ));
        assert!(matches!(crossfade(&one_frame, 0, 1, 0, 5), Err(MatchError::NoSearchableFrames { .. })));
        assert!(matches!(crossfade(&db, 3, 9, 2, 5), Err(MatchError::NoSearchableFrames { .. })));
        assert!(matches!(crossfade(&db, 14, 1, 2, 5), Err(MatchError::FrameOutOfRange { .. })));
        let cand = crossfade_candidates(&db, 1, 2);
        assert!(matches!(nearest_pose(&db, &[0.0, 1.0], &cand), Err(MatchError::Length { .. })));
        assert!(matches!(nearest_pose(&db, &[f64::NAN], &cand), Err(MatchError::NonFinite { .. })));
        assert!(matches!(nearest_pose(&db, &[0.0], &FrameSet::empty(3)), Err(MatchError::Mismatch { .. })));
    }
}
