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
        Self {
            search_interval: 0.1,
            halflife: 0.1,
            exclude_radius: None,
        }
    }
}

impl ControllerSettings {
    /// Frames between searches: $\max(1, \operatorname{round}(\text{interval}\cdot\text{fps}))$.
    pub fn interval_frames(&self, fps: f64) -> usize {
        // A finite positive interval times fps; saturating cast of a rounded value.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
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
    current: usize,
    until_search: usize,
    inert: Inertializer,
    src_v: Vec<f64>,
    dst_v: Vec<f64>,
    out: Vec<f64>,
}

impl<'a> Controller<'a> {
    /// Starts at `start` (shown when the request arrives) with target label `target`; the
    /// first search runs at output frame `first_search`.
    ///
    /// # Errors
    /// [`MatchError::Mismatch`] if `feats` was built for another database,
    /// [`MatchError::FrameOutOfRange`], [`MatchError::Param`] for bad settings,
    /// [`MatchError::NoSearchableFrames`] if `target` has no searchable frame.
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
            current: start,
            until_search: first_search,
            inert,
            src_v: vec![0.0; db.dim()],
            dst_v: vec![0.0; db.dim()],
            out: db.row(start).to_vec(),
        };
        c.set_target(target)?;
        Ok(c)
    }

    /// Requests label `target`; the change takes effect at the next scheduled search
    /// (call [`Controller::search_next_step`] too to react at once, as the reference does
    /// on a sharp input change).
    ///
    /// # Errors
    /// [`MatchError::NoSearchableFrames`]; the previous target is kept.
    pub fn set_target(&mut self, target: u32) -> Result<()> {
        let allowed = self.feats.searchable_with_label(self.db, target)?;
        if allowed.is_empty() {
            return Err(MatchError::NoSearchableFrames {
                label: target,
                needed: self.feats.continuation(),
            });
        }
        self.target = target;
        self.allowed = allowed;
        Ok(())
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
        if self.until_search == 0 || at_end {
            self.until_search = self.interval;
            let continues_in_target = !at_end && db.label(cur + 1) == self.target;
            if !continues_in_target {
                let query = self.feats.features(cur);
                let exclude = self.exclude_radius.map(|radius| Exclusion { center: cur, radius });
                best = self.feats.search(query, &self.allowed, exclude)?;
                match best {
                    Some(m) => {
                        db.velocity_into(cur, &mut self.src_v);
                        db.velocity_into(m.frame, &mut self.dst_v);
                        self.inert.transition(db.row(cur), &self.src_v, db.row(m.frame), &self.dst_v);
                        self.current = m.frame;
                        switched = true;
                    }
                    None if at_end => {
                        return Err(MatchError::DeadEnd {
                            frame: cur,
                            label: self.target,
                        })
                    }
                    None => {}
                }
            }
        }
        self.until_search -= 1;
        // Either the old frame had a next one, or we jumped to a searchable frame.
        self.current += 1;
        self.inert.update(1.0 / db.fps());
        self.inert.apply(db.row(self.current), &mut self.out);
        Ok(StepInfo {
            frame: self.current,
            label: db.label(self.current),
            switched,
            best,
        })
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
    let mut out = Playback::new(db.dim(), request.target, request.frames);
    for _ in 0..request.frames {
        let s = c.step()?;
        out.push(c.output(), s.frame, s.label, s.switched, 0.0);
    }
    Ok(out)
}
