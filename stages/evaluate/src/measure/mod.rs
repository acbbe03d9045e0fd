//! Measuring one answered request of one system — every system by the same code, on the
//! same requests, against the same training reference ([`Training`]).

pub mod arrival;
pub mod liveliness;
pub mod motion;
pub mod nearest;
pub mod plausibility;
pub mod variety;

use std::ops::Range;

use reprise_artifact::transitions::{Answer, Request};
use reprise_stagekit::StageResult;

use crate::systems::Played;
use crate::training::{RigRef, Training};
pub use plausibility::{Plausibility, Reference as PlausibilityReference, Space};

/// The phases of an answer (frame ranges of its curves), request at frame `a`, first frame
/// of B at `a + L`, blend length `k`. Only the frames after the request are measured; the
/// hold is context.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// $[0, a]$: before and at the request (context, the same start for every system).
    Hold,
    /// $(a, a + L)$: on the way to B.
    Reach,
    /// $[a + L, a + L + k)$: the first `k` frames of B (the blend or the inertialization).
    Blend,
    /// $[a + L + k, \text{end})$: playing on in B.
    Settle,
}

impl Phase {
    /// Every phase, in time order.
    pub const ALL: [Phase; 4] = [Phase::Hold, Phase::Reach, Phase::Blend, Phase::Settle];
    /// The phases after the request, which are measured.
    pub const AFTER: [Phase; 3] = [Phase::Reach, Phase::Blend, Phase::Settle];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Hold => "hold",
            Phase::Reach => "reach",
            Phase::Blend => "blend",
            Phase::Settle => "settle",
        }
    }

    /// The frames of each phase in an answer of `len` frames, in [`Phase::ALL`] order.
    pub fn ranges(len: usize, asked: usize, latency: usize, k: usize) -> [Range<usize>; 4] {
        let a = (asked + 1).min(len);
        let b = (asked + latency).clamp(a, len);
        let c = (b + k).min(len);
        [0..a, a..b, b..c, c..len]
    }
}

/// What one answered request measured.
#[derive(Debug, Clone)]
pub struct Measured {
    /// The request's id.
    pub request: i64,
    /// Label A.
    pub from: String,
    /// Label B.
    pub to: String,
    /// Seconds from the request to the system's label switch (its first frame of B).
    pub switch_latency: f64,
    /// Seconds from the request to arrival as a viewer sees it ([`arrival`]); `None`: the
    /// answer never looks like B.
    pub perceived_latency: Option<f64>,
    /// Whether a third label plays between the request and the label switch.
    pub routed: bool,
    /// Largest peak vertex speed from the request on / the training p99 (a pose jump).
    pub jump: f64,
    /// Peak acceleration and jerk in the fixed window around the label switch, / the
    /// training p95s.
    pub discontinuity: motion::Discontinuity,
    /// Per-frame mesh speeds after the request against B's training speeds.
    pub liveliness: liveliness::Liveliness,
    /// Plausibility of the strided frames, by phase, space and reference.
    pub plausibility: Plausibility,
    /// Peak vertex speed at offsets `-SPEED_BEFORE..=SPEED_AFTER` from the first frame of
    /// B (NaN outside the answer).
    pub speed: Vec<f64>,
}

/// Frames before and after the first target frame in the velocity figure.
pub const SPEED_BEFORE: i64 = 12;
/// See [`SPEED_BEFORE`].
pub const SPEED_AFTER: i64 = 30;

/// How to measure: the same for every system.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Blend length (frames): the phases' split.
    pub k: usize,
    /// Plausibility on every n-th frame after the request.
    pub stride: usize,
    /// Frames in a row the pose must look like B for arrival ([`arrival`]).
    pub arrival_frames: usize,
    /// Frames of the discontinuity window around the label switch.
    pub discontinuity_window: usize,
}

/// Measures one answered request (`None` when the answer is a refusal).
pub fn measure(
    rig: RigRef<'_>,
    training: &Training,
    settings: Settings,
    request: &Request,
    answer: &Answer,
    played: &Played,
) -> StageResult<Option<Measured>> {
    if answer.latency.is_none() {
        return Ok(None);
    }
    let m = reprise_stagekit::rig::meshes(rig, &played.controls)?;
    Ok(measure_meshed(training, settings, request, answer, played, &m))
}

/// [`measure`] with the answer's meshes already evaluated (`m`: one per frame, flattened).
pub fn measure_meshed(
    training: &Training,
    settings: Settings,
    request: &Request,
    answer: &Answer,
    played: &Played,
    m: &[f64],
) -> Option<Measured> {
    let latency = answer.latency?;
    let frames = played.controls.len();
    let asked = (answer.asked.max(0) as usize).min(frames.saturating_sub(1));
    let switch = (asked as i64 + latency).clamp(0, frames as i64) as usize;
    let phases = Phase::ranges(frames, asked, latency.max(0) as usize, settings.k);
    let to = training.label_index(&request.to);
    let mut near = nearest::Cache::new(training, &played.controls, m);
    let arrived = to.and_then(|b| arrival::find(&mut near, asked, b, settings.arrival_frames));
    let motion = motion::measure(m, training, asked, switch, settings.discontinuity_window);
    let routed =
        played.model.get(asked + 1..switch).unwrap_or_default().iter().any(|l| *l != request.from && *l != request.to);
    Some(Measured {
        request: request.request,
        from: request.from.clone(),
        to: request.to.clone(),
        switch_latency: latency as f64 / training.fps,
        perceived_latency: arrived.map(|t| (t - asked) as f64 / training.fps),
        routed,
        jump: motion.jump,
        discontinuity: motion.discontinuity,
        speed: motion.speed,
        liveliness: liveliness::measure(m, training, to, &phases),
        plausibility: Plausibility::measure(&mut near, &phases, settings.stride),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::training::tests::{labeled, rig, training};

    /// Phases of an answer of 20 frames asked at 5, reaching B 4 frames later, k = 3.
    #[test]
    fn phases_split_the_answer() {
        assert_eq!(Phase::ranges(20, 5, 4, 3), [0..6, 6..9, 9..12, 12..20]);
        // Immediately in B, and an answer shorter than its blend.
        assert_eq!(Phase::ranges(8, 0, 1, 12), [0..1, 1..1, 1..8, 8..8]);
    }

    fn request() -> Request {
        Request { request: 1, from: "a".into(), to: "b".into(), segment_id: 0, clip: "clip0".into(), frame: 0 }
    }

    /// Replaying training frames of A then B: a cut from the end of A to the start of B is a
    /// pose jump (the loser here), the same frames reached through a slow walk are not;
    /// replayed frames are 0 from the raw set, and latency is in seconds.
    #[test]
    fn a_cut_is_a_jump_and_replayed_frames_are_plausible() {
        let (t, lf, rig) = (training(), labeled(), rig());
        let rows = |r: std::ops::Range<usize>| r.map(|i| lf.frames.row(i).to_vec()).collect::<Vec<_>>();
        let settings = Settings { k: 3, stride: 1, arrival_frames: 3, discontinuity_window: 8 };
        let cut = Played { controls: [rows(20..30), rows(30..40)].concat(), model: vec![], x: vec![] };
        let answer = Answer::reached(4, 6);
        let m = measure(&rig, &t, settings, &request(), &answer, &cut).unwrap().unwrap();
        assert!((m.switch_latency - 6.0 / 24.0).abs() < 1e-12);
        // The cut lands on B's first frame, whose pose is also A's first (both start at the
        // origin): a viewer sees B from the next frame on.
        assert!((m.perceived_latency.unwrap() - 7.0 / 24.0).abs() < 1e-12, "{:?}", m.perceived_latency);
        assert!(m.jump > 2.0, "a cut jumps: {}", m.jump);
        assert!(m.plausibility.values(PlausibilityReference::Raw, Space::Scaled, None).iter().all(|v| *v < 1e-9));
        assert_eq!(m.plausibility.values(PlausibilityReference::Raw, Space::Mesh, Some(Phase::Blend)).len(), 3);
        // A slow walk from A's last pose to B's first: 40 small steps.
        let (a, b) = (lf.frames.row(29).to_vec(), lf.frames.row(30).to_vec());
        let walk: Vec<Vec<f64>> =
            (0..40).map(|i| a.iter().zip(&b).map(|(x, y)| x + (y - x) * i as f64 / 39.0).collect()).collect();
        let smooth = Played { controls: [rows(20..30), walk, rows(30..40)].concat(), model: vec![], x: vec![] };
        let m = measure(&rig, &t, settings, &request(), &Answer::reached(9, 40), &smooth).unwrap().unwrap();
        assert!(m.jump < 2.0, "a walk does not jump: {}", m.jump);
        let mid = m.plausibility.values(PlausibilityReference::Raw, Space::Scaled, Some(Phase::Reach));
        assert!(mid.iter().any(|v| *v > 1.0), "the walk leaves the training poses: {mid:?}");
        // The walk retraces A's own path back to the origin (A moves along c0 from 0): a
        // viewer sees A all the way and B only once B's frames play after it.
        let seen = m.perceived_latency.unwrap();
        assert!((40.0 / 24.0..50.0 / 24.0).contains(&seen), "{seen}");
        assert!(measure(&rig, &t, settings, &request(), &Answer::failed("x"), &smooth).unwrap().is_none());
    }
}
