//! The motion-matching controller: plays the database from a start frame and, on a
//! schedule, jumps to the best frame of the requested label, inertializing every jump
//! (method.md §7.2–§7.5; Holden's `controller.cpp` update loop).
//!
//! **Timeline.** The request arrives while start frame $s$ is shown; output frame $k = 0$
//! is the next one. Each [`Controller::step`] first searches if one is due, then advances
//! one frame and decays the offsets by $1/\text{fps}$:
//!
//! - a search is due every $c = \max(1, \operatorname{round}(\text{interval}\cdot\text{fps}))$
//!   frames, the first at output frame `first_search` (the phase of the search timer when
//!   the request arrives, uniform in $0..c$ for a request at a random time), and always when
//!   the playing frame is the last of its segment (then the timer restarts);
//! - **query** = the playing frame's own normalised features $\hat f_{\text{cur}}$: the pose
//!   part is the current pose and, a face having no trajectory, the future part is the
//!   current frame's continuation ($y$ at $+4, +8, +12$). The controller thus asks for "a
//!   frame of the target label that is where I am and moves the way I am moving";
//! - **switch rule** (the reference's "switch only if better than the continuation"): the
//!   continuation competes only if it plays on in the target label (its next frame has the
//!   target label). Its cost is $c(\text{cur}) = 0$ because the query is its own feature
//!   vector, so no target frame beats it: once in the target, playback continues to the
//!   segment end and re-searches there. While the continuation is not in the target (the
//!   first search after a request from label $A \ne B$), the best target frame is taken
//!   whatever its cost — any $B$ frame reaches the goal;
//! - **switch** to frame $j$: offsets take $(z_{\text{cur}}, \dot z_{\text{cur}}) \to (z_j,
//!   \dot z_j)$ ([`crate::Inertializer::transition`]), playback continues at $j + 1$
//!   (searchable frames have continuation), output $= z_{j+1} + o_x$ after one decay.
//!
//! **Short labels.** The target's candidates are its searchable frames with their own
//! continuation $c_L$ ([`FeatureDb::continuation_of`]): the full $c = \max(o_{\max}, 1)$
//! frames, or, for a label whose segments are all too short for it, its longest segment's
//! length minus 1 — such a label is served with a shorter window instead of failing
//! ([`Controller::continuation`], [`Playback::window`]). Only a label of one-frame segments
//! cannot be jumped into.
//!
//! The latency (first output frame from the target) is therefore
//! $\min(\texttt{first\_search},\ \text{segment\_end}(s) - s)$ for a start outside the target.

use crate::database::{Database, FrameSet};
use crate::error::{MatchError, Result};
use crate::features::FeatureDb;
use crate::playback::Playback;
use crate::search::{Exclusion, Match};
use crate::spring::Inertializer;

/// Controller settings. Defaults: search every 0.1 s, half-life 0.1 s, no exclusion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerSettings {
    /// Seconds between scheduled searches (finite, positive).
    pub search_interval: f64,
    /// Inertialization half-life $h$ in seconds; 0 = hard cuts (no inertialization).
    pub halflife: f64,
    /// Never jump to a frame within this many frames of the playing one
    /// (`ignore_surrounding`).
    pub exclude_radius: Option<usize>,
}

impl Default for ControllerSettings {
    fn default() -> Self {
        Self { search_interval: 0.1, halflife: 0.1, exclude_radius: None }
    }
}

impl ControllerSettings {
    /// Frames between searches: $\max(1, \operatorname{round}(\text{interval}\cdot\text{fps}))$.
    pub fn interval_frames(&self, fps: f64) -> usize {
        // A finite positive interval times fps; saturating cast of a rounded value.
        let c = (self.search_interval * fps).round() as usize;
        c.max(1)
    }

    fn check(&self) -> Result<()> {
        if self.search_interval.is_finite() && self.search_interval > 0.0 {
            Ok(())
        } else {
            Err(MatchError::Param {
                name: "search_interval",
                reason: format!("must be finite and positive seconds, got {}", self.search_interval),
            })
        }
    }
}

/// What one [`Controller::step`] did; the output controls are [`Controller::output`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepInfo {
    /// Database frame now playing.
    pub frame: usize,
    /// Its label.
    pub label: u32,
    /// Whether this step jumped.
    pub switched: bool,
    /// The best target frame, if a search ran (it is skipped while the continuation plays
    /// on in the target and so cannot be beaten).
    pub best: Option<Match>,
}

/// A running motion-matching playback over one database.
#[derive(Debug, Clone)]
pub struct Controller<'a> {
    db: &'a Database,
    feats: &'a FeatureDb,
    exclude_radius: Option<usize>,
    interval: usize,
    target: u32,
    allowed: FrameSet,
    continuation: usize,
    current: usize,
    until_search: usize,
    inert: Inertializer,
    src_v: Vec<f64>,
    dst_v: Vec<f64>,
    out: Vec<f64>,
    /// The frame the last step's search was made from, if it searched.
    searched_from: Option<usize>,
}

impl<'a> Controller<'a> {
    /// Starts at `start` (shown when the request arrives) with target label `target`; the
    /// first search runs at output frame `first_search`.
    ///
    /// # Errors
    /// [`MatchError::Mismatch`] if `feats` was built for another database,
    /// [`MatchError::FrameOutOfRange`], [`MatchError::Param`] for bad settings,
    /// [`MatchError::NoSearchableFrames`] if `target` has no searchable frame (no frame, or
    /// only one-frame segments).
    pub fn new(
        db: &'a Database,
        feats: &'a FeatureDb,
        start: usize,
        target: u32,
        first_search: usize,
        settings: &ControllerSettings,
    ) -> Result<Self> {
        feats.check_db(db)?;
        db.check_frame(start)?;
        settings.check()?;
        let inert = Inertializer::new(db.dim(), settings.halflife)?;
        let mut c = Self {
            db,
            feats,
            exclude_radius: settings.exclude_radius,
            interval: settings.interval_frames(db.fps()),
            target,
            allowed: FrameSet::empty(db.len()),
            continuation: feats.continuation(),
            current: start,
            until_search: first_search,
            inert,
            src_v: vec![0.0; db.dim()],
            dst_v: vec![0.0; db.dim()],
            out: db.row(start).to_vec(),
            searched_from: None,
        };
        c.set_target(target)?;
        Ok(c)
    }

    /// Requests label `target`; the change takes effect at the next scheduled search
    /// (call [`Controller::search_next_step`] too to react at once, as the reference does
    /// on a sharp input change).
    ///
    /// # Errors
    /// [`MatchError::NoSearchableFrames`] if `target` has no searchable frame (no frame, or
    /// only one-frame segments); the previous target is kept.
    pub fn set_target(&mut self, target: u32) -> Result<()> {
        let allowed = self.feats.searchable_with_label(self.db, target)?;
        let continuation = self.feats.continuation_of(target);
        let Some(continuation) = continuation.filter(|_| !allowed.is_empty()) else {
            return Err(MatchError::NoSearchableFrames { label: target, needed: 1 });
        };
        self.target = target;
        self.allowed = allowed;
        self.continuation = continuation;
        Ok(())
    }

    /// The continuation the target is searched with, in frames
    /// ([`FeatureDb::continuation_of`]): [`FeatureDb::continuation`], or less for a label
    /// whose segments are all shorter.
    pub fn continuation(&self) -> usize {
        self.continuation
    }

    /// Makes the next step search regardless of the timer.
    pub fn search_next_step(&mut self) {
        self.until_search = 0;
    }

    /// Frames between scheduled searches.
    pub fn interval(&self) -> usize {
        self.interval
    }

    /// The database frame shown last.
    pub fn current_frame(&self) -> usize {
        self.current
    }

    /// The controls shown last (scaled): animation + inertialization offset.
    pub fn output(&self) -> &[f64] {
        &self.out
    }

    /// The frames a search from `cur` must not return.
    fn exclusion(&self, cur: usize) -> Option<Exclusion> {
        self.exclude_radius.map(|radius| Exclusion { center: cur, radius })
    }

    /// The `k` best candidates of the search the last [`Controller::step`] made, best
    /// first ([`FeatureDb::search_top`]; the first is [`StepInfo::best`]); empty if it
    /// made none. Call it before the next [`Controller::set_target`].
    ///
    /// # Errors
    /// As [`FeatureDb::search_top`].
    pub fn candidates(&self, k: usize) -> Result<Vec<Match>> {
        match self.searched_from {
            Some(cur) => self.feats.search_top(self.feats.features(cur), &self.allowed, self.exclusion(cur), k),
            None => Ok(Vec::new()),
        }
    }

    /// Produces the next output frame.
    ///
    /// # Errors
    /// [`MatchError::DeadEnd`] if playback reaches a segment end and the search finds no
    /// frame (possible only when the exclusion removes every candidate).
    pub fn step(&mut self) -> Result<StepInfo> {
        let (db, cur) = (self.db, self.current);
        let at_end = !db.has_next(cur);
        let mut switched = false;
        let mut best = None;
        self.searched_from = None;
        if self.until_search == 0 || at_end {
            self.until_search = self.interval;
            let continues_in_target = !at_end && db.label(cur + 1) == self.target;
            if !continues_in_target {
                let query = self.feats.features(cur);
                best = self.feats.search(query, &self.allowed, self.exclusion(cur))?;
                self.searched_from = Some(cur);
                match best {
                    Some(m) => {
                        db.velocity_into(cur, &mut self.src_v);
                        db.velocity_into(m.frame, &mut self.dst_v);
                        self.inert.transition(db.row(cur), &self.src_v, db.row(m.frame), &self.dst_v);
                        self.current = m.frame;
                        switched = true;
                    }
                    None if at_end => return Err(MatchError::DeadEnd { frame: cur, label: self.target }),
                    None => {}
                }
            }
        }
        self.until_search -= 1;
        // Either the old frame had a next one, or we jumped to a searchable frame.
        self.current += 1;
        self.inert.update(1.0 / db.fps());
        self.inert.apply(db.row(self.current), &mut self.out);
        Ok(StepInfo { frame: self.current, label: db.label(self.current), switched, best })
    }
}

/// A transition request: from `start` (shown when the request arrives) to label `target`,
/// first search at output frame `first_search`, `frames` output frames in all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TransitionRequest {
    /// Database frame shown when the request arrives.
    pub start: usize,
    /// Requested label.
    pub target: u32,
    /// Output frame of the first scheduled search (timer phase), usually `0..interval`.
    pub first_search: usize,
    /// Output frames to produce (the timeout: [`Playback::latency`] is `None` if the target
    /// is not reached within them).
    pub frames: usize,
}

/// Runs the controller for `request.frames` frames.
///
/// # Errors
/// As [`Controller::new`] and [`Controller::step`].
pub fn transition(
    db: &Database,
    feats: &FeatureDb,
    request: &TransitionRequest,
    settings: &ControllerSettings,
) -> Result<Playback> {
    let mut c = Controller::new(db, feats, request.start, request.target, request.first_search, settings)?;
    let mut out = Playback::new(db.dim(), request.target, c.continuation(), request.frames);
    for _ in 0..request.frames {
        let s = c.step()?;
        out.push(c.output(), s.frame, s.label, s.switched, 0.0);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{short_clips, two_sines};

    fn request(start: usize, target: u32, first_search: usize, frames: usize) -> TransitionRequest {
        TransitionRequest { start, target, first_search, frames }
    }

    /// The controller reaches label 1 at the first search (output frame `first_search` = 1):
    /// playing frame 11, it jumps to its phase twin 131 and outputs 132; then label 1 plays
    /// on without further jumps.
    #[test]
    fn reaches_the_target_at_the_first_search() {
        let (db, feats) = two_sines(1.0, 24);
        let s = ControllerSettings::default();
        let out = transition(&db, &feats, &request(10, 1, 1, 40), &s).unwrap();
        assert_eq!(out.latency, Some(1));
        assert_eq!(out.frames[..3], [11, 132, 133]);
        assert_eq!(out.labels[0], 0);
        assert!(out.labels[1..].iter().all(|&l| l == 1));
        assert_eq!(out.switches.iter().filter(|&&b| b).count(), 1);
        assert!(out.switches[1]);
        // Requesting the label already playing never jumps.
        let same = transition(&db, &feats, &request(10, 0, 0, 40), &s).unwrap();
        assert_eq!(same.latency, Some(0));
        assert_eq!(same.frames, (11..51).collect::<Vec<_>>());
    }

    /// Latency is set by the search cadence: with searches every c frames from output frame
    /// 0, a request after r frames is answered at the next multiple of c, i.e. latency
    /// (⌈r/c⌉·c − r) frames: c = round(0.1·24) = 2, r = 5 → 1; c = round(0.25·24) = 6,
    /// r = 7 → 5.
    #[test]
    fn latency_follows_the_search_cadence() {
        let (db, feats) = two_sines(1.0, 24);
        for (interval, r, expected) in [(0.1, 5, 1), (0.25, 7, 5), (0.25, 6, 0)] {
            let s = ControllerSettings { search_interval: interval, ..ControllerSettings::default() };
            let mut c = Controller::new(&db, &feats, 10, 0, 0, &s).unwrap();
            for _ in 0..r {
                assert_eq!(c.step().unwrap().label, 0);
            }
            c.set_target(1).unwrap();
            let latency = (0..20).position(|_| c.step().unwrap().label == 1);
            assert_eq!(latency, Some(expected), "interval {interval}, request after {r}");
        }
    }

    /// The end of the playing segment forces a search before the timer: start 115 of a
    /// segment ending at 119 reaches label 1 at output frame 4 although the first scheduled
    /// search is at 10.
    /// After a step that searched, the candidates begin with its best match and are all
    /// target frames; after one that did not, there are none.
    #[test]
    fn candidates_are_the_last_searchs_runners_up() {
        let (db, feats) = two_sines(1.0, 24);
        let mut c = Controller::new(&db, &feats, 10, 1, 0, &ControllerSettings::default()).unwrap();
        let info = c.step().unwrap();
        let top = c.candidates(5).unwrap();
        assert_eq!(top.len(), 5);
        assert_eq!(Some(top[0]), info.best);
        assert!(top.iter().all(|m| db.label(m.frame) == 1));
        assert!(top.windows(2).all(|p| p[0].cost <= p[1].cost));
        let next = c.step().unwrap();
        assert!(next.best.is_none() && c.candidates(5).unwrap().is_empty());
    }

    #[test]
    fn segment_end_forces_a_search() {
        let (db, feats) = two_sines(1.0, 24);
        let out = transition(&db, &feats, &request(115, 1, 10, 20), &ControllerSettings::default()).unwrap();
        assert_eq!(out.latency, Some(4));
        assert_eq!(out.frames[3], 119);
        // At the end of label 1's segment playback jumps within label 1 and goes on.
        let out = transition(&db, &feats, &request(230, 1, 0, 30), &ControllerSettings::default()).unwrap();
        assert_eq!(out.frames[8], 239);
        assert!(out.switches[9] && out.labels.iter().all(|&l| l == 1));
    }

    /// Timeout: a first search beyond the frames played leaves the target unreached.
    #[test]
    fn unreached_within_the_frames_is_none() {
        let (db, feats) = two_sines(1.0, 24);
        let out = transition(&db, &feats, &request(10, 1, 50, 20), &ControllerSettings::default()).unwrap();
        assert_eq!((out.latency, out.len()), (None, 20));
    }

    /// Jump of control 2 (0 in label 0, `gap` in label 1) at the switch frame, and the
    /// largest per-frame change over the 10 frames after it.
    fn switch_jump(fps: u32, halflife: f64) -> (f64, f64) {
        let (db, feats) = two_sines(2.0, fps);
        let s = ControllerSettings { halflife, ..ControllerSettings::default() };
        let out = transition(&db, &feats, &request(fps as usize, 1, 1, 30), &s).unwrap();
        assert!(out.switches[1]);
        let x: Vec<f64> = (0..out.len()).map(|k| out.row(k)[2]).collect();
        let after = x[1..12].windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
        ((x[1] - x[0]).abs(), after)
    }

    /// §7.6 (d): inertialized output is continuous across the switch. At 24 fps the jump is
    /// a small fraction of the gap and smaller than the output's own later per-frame
    /// changes; it shrinks as O(Δt²) with the frame rate (C¹: 24 → 96 fps divides it by
    /// ≈ 12; a velocity kink would give ≈ 4). Without inertialization (half-life 0) the
    /// jump is the whole gap and does not shrink, so the test can fail.
    #[test]
    fn inertialized_switch_is_continuous() {
        let (j24, after24) = switch_jump(24, 0.1);
        let (j96, _) = switch_jump(96, 0.1);
        assert!(j24 < 0.15 * 2.0, "jump {j24}");
        assert!(j24 < after24, "jump {j24} vs later changes {after24}");
        assert!(j24 / j96 > 8.0, "order: {j24} / {j96}");
        let (h24, after) = switch_jump(24, 0.0);
        let (h96, _) = switch_jump(96, 0.0);
        assert!((h24 - 2.0).abs() < 1e-12 && (h96 - 2.0).abs() < 1e-12);
        assert!(h24 > after);
    }

    /// Label 1's only segments are 6 frames long: no frame has the 12 frames of
    /// continuation the features look ahead, which used to fail every request into it
    /// (`NoSearchableFrames`). It is now searched with $c_1 = 5$ frames: its candidates are
    /// the segments' first frames, so every jump shows a segment's frames 2..6 and the
    /// segment end forces the next search 5 frames later.
    #[test]
    fn a_short_label_is_reached_with_a_shorter_continuation() {
        let (db, feats) = short_clips(6, 8);
        let s = ControllerSettings::default();
        assert_eq!((feats.continuation(), feats.continuation_of(1)), (12, Some(5)));
        let out = transition(&db, &feats, &request(10, 1, 1, 40), &s).unwrap();
        assert_eq!((out.latency, out.window), (Some(1), 5));
        assert!(out.labels[1..].iter().all(|&l| l == 1));
        let switches: Vec<usize> = (0..out.len()).filter(|&k| out.switches[k]).collect();
        assert_eq!(switches, (1..40).step_by(5).collect::<Vec<_>>());
        for &k in &switches {
            assert_eq!(out.frames[k], db.segment_start(out.frames[k]) + 1, "output frame {k}");
        }
        // The long label is searched as before: the full continuation, the full-window set.
        let full = FrameSet::from_predicate(db.len(), |t| db.label(t) == 0 && t + 12 <= db.segment_end(t));
        assert_eq!(feats.searchable_with_label(&db, 0).unwrap(), full);
        let back = transition(&db, &feats, &request(130, 0, 0, 20), &s).unwrap();
        assert_eq!((back.latency, back.window), (Some(0), 12));
        // Label 2 has only one-frame segments: still no frame to jump to.
        assert!(matches!(
            transition(&db, &feats, &request(10, 2, 0, 5), &s),
            Err(MatchError::NoSearchableFrames { label: 2, needed: 1 })
        ));
    }

    /// Regression (a character whose clips of a label are 11 frames, window 12): motion
    /// matching answered none of the requests into that label; it now reaches it, searching
    /// with a 10-frame continuation.
    #[test]
    fn regression_eleven_frame_clips_are_searched_with_a_ten_frame_continuation() {
        let (db, feats) = short_clips(11, 5);
        assert_eq!(feats.continuation_of(1), Some(10));
        let out = transition(&db, &feats, &request(30, 1, 0, 48), &ControllerSettings::default()).unwrap();
        assert_eq!((out.latency, out.window), (Some(0), 10));
        assert!(out.labels.iter().all(|&l| l == 1));
        assert!((0..out.len())
            .filter(|&k| out.switches[k])
            .all(|k| db.segment_start(out.frames[k]) + 1 == out.frames[k]));
    }

    #[test]
    fn bad_requests_are_errors() {
        let (db, feats) = two_sines(1.0, 24);
        let s = ControllerSettings::default();
        assert!(matches!(
            transition(&db, &feats, &request(10, 7, 0, 5), &s),
            Err(MatchError::NoSearchableFrames { label: 7, needed: 1 })
        ));
        assert!(matches!(
            transition(&db, &feats, &request(240, 1, 0, 5), &s),
            Err(MatchError::FrameOutOfRange { frame: 240, .. })
        ));
        let bad = ControllerSettings { search_interval: 0.0, ..s };
        assert!(matches!(transition(&db, &feats, &request(0, 1, 0, 5), &bad), Err(MatchError::Param { .. })));
        let bad = ControllerSettings { halflife: f64::NAN, ..s };
        assert!(matches!(transition(&db, &feats, &request(0, 1, 0, 5), &bad), Err(MatchError::Param { .. })));
        let (other, _) = two_sines(1.0, 12);
        assert!(matches!(transition(&other, &feats, &request(0, 1, 0, 5), &s), Err(MatchError::Mismatch { .. })));
        // A label whose only segment is one frame: no frame to jump to.
        let z = vec![0.0; 26];
        let labels: Vec<u32> = (0..26).map(|t| u32::from(t >= 25)).collect();
        let db = Database::new(z.clone(), 1, labels.clone(), &labels, 24.0).unwrap();
        let feats = FeatureDb::build(&db, &z, 1, &crate::FeatureParams::default()).unwrap();
        let mut c = Controller::new(&db, &feats, 0, 0, 0, &s).unwrap();
        assert!(matches!(c.set_target(1), Err(MatchError::NoSearchableFrames { label: 1, needed: 1 })));
        assert_eq!(c.continuation(), 12, "the previous target is kept");
        // Every candidate excluded at a segment end: a dead end, not a panic.
        let s = ControllerSettings { exclude_radius: Some(100), ..s };
        let mut c = Controller::new(&db, &feats, 10, 0, 100, &s).unwrap();
        let err = (0..20).map(|_| c.step()).find(Result::is_err);
        assert!(matches!(err, Some(Err(MatchError::DeadEnd { frame: 24, label: 0 }))));
    }
}
