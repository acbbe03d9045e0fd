//! The command engine (§5.3): a [`Script`] of MOVE / IDLE / TRANSITION / PLAY commands
//! becomes a per-frame path with radii; the particle ([`crate::particle`]) follows it in
//! the current model's latent space under the density force and the random force; each
//! frame is reconstructed to rig controls, blended across model switches.
//!
//! Forces on the particle besides the constraint:
//! - toward probable regions (Eq. 11–12): $S\,\nabla\tilde p/\lVert\nabla\tilde p\rVert$,
//!   $S = a\,(1 + e^{(\tilde p(x) - v)/l})^{-1}$, with $\tilde p$ the model's relative latent
//!   density ([`reprise_numerics::gplvm::LatentDensity::relative`]);
//! - the random force ([`RandomForce`]), one draw per script;
//! - a linear drag $-c\,\dot x$ (a deviation: the paper names no damping; without it the
//!   random force keeps pumping energy into a particle that only the rim of the disc
//!   slows down). `drag = 0` restores the paper.
//!
//! **Commands are event-driven.** Every approach — to a MOVE target, an IDLE pose, a
//! bridge, a segment's first frame — lays the path point along the way at the latent
//! **speed limit** (by default each model's own typical speed: the median over its
//! training segments of $\lVert x_{t+1} - x_t\rVert\cdot\text{fps}$), so a farther target
//! takes longer; when the path point has arrived, the command waits until the particle is
//! within the command's radius of the target and no faster than the limit (arrived), and
//! fails with [`SynthError::Timeout`] after `timeout_seconds`. Nothing runs on a clock
//! but IDLE's own duration, PLAY's frames and the blend.
//!
//! TRANSITION: among the bridges from the current label to the target, the one whose
//! $x_1$ is nearest the particle (straight-line latent distance, the path it takes); go
//! there and arrive; then, on arrival, idle both models' particles — the old one at $x_1$,
//! the new one from rest at $x_2$ — for `blend_frames` frames while the output blends the
//! two live rig-space streams, $p = (1-w)\,g_{old}(x_{old}(t)) + w\,g_{new}(x_{new}(t))$,
//! $w = 3s^2 - 2s^3$, $s = f/k$; the new model's particle carries on. Without a direct
//! bridge it goes through the third label whose two bridges are closest; without one
//! either, it is an error.
//!
//! PLAY: reach the segment's first latent (arrive within the tight radius), then play its
//! embedding one training frame per output frame, the particle carried along it (a
//! deviation: the paper's particle follows the path under the constraint, which diverges
//! on fast training frames in a disc small enough to track them).

use reprise_numerics::gplvm::LatentModel;
use reprise_numerics::vector::{dist, norm};

use crate::method::{landing, training_means, BridgeChoice, Dynamics, IdleRule, Landing, Method};
use crate::particle::{step_frame, Leg, ParticleParams, State};
use crate::path::{graph_path, resample, EdgeCost};
use crate::random::RandomForce;
use crate::script::{Command, PathKind, Pose, Script};

/// Why a script cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SynthError {
    /// A label no model has.
    #[error("unknown label `{label}`; the models are: {known}")]
    UnknownLabel {
        /// Asked for.
        label: String,
        /// What there is.
        known: String,
    },
    /// A pose that names no training frame, or a malformed one.
    #[error("label `{label}`: {what}")]
    BadPose {
        /// Current label.
        label: String,
        /// What is wrong.
        what: String,
    },
    /// A target not reached in time.
    #[error("label `{label}`: {what} not reached within {seconds} s (the particle is {distance:.3} latent units away, radius {radius})")]
    Timeout {
        /// Current label.
        label: String,
        /// What was being reached.
        what: String,
        /// The time-out.
        seconds: f64,
        /// Distance left.
        distance: f64,
        /// The arrival radius.
        radius: f64,
    },
    /// The particle's state became non-finite (an unstable constraint or force).
    #[error("label `{label}`: the particle diverged while reaching {what}")]
    Diverged {
        /// Current label.
        label: String,
        /// What was being reached.
        what: String,
    },
    /// No bridge connects two labels, directly or through a third.
    #[error("no bridge from `{from}` to `{to}`, directly or through a third label")]
    NoBridge {
        /// From.
        from: String,
        /// To.
        to: String,
    },
    /// The frame sink of a [`Synth`] stopped taking frames (a live session moved on).
    #[error("stopped: the frames' consumer took no more")]
    Stopped,
    /// A checkpoint that does not fit the library.
    #[error("a checkpoint for model {model} with {q} latent dimensions does not fit this library")]
    BadCheckpoint {
        /// Its model.
        model: usize,
        /// Its latent dimension.
        q: usize,
    },
}

/// A training frame of a model: where it is in the corpus and in latent space.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingFrame {
    /// Segment id.
    pub segment: i64,
    /// Clip.
    pub clip: String,
    /// Frame in the clip.
    pub frame: i64,
    /// Latent point.
    pub x: Vec<f64>,
}

/// A bridge as the engine needs it.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// From label.
    pub from: String,
    /// To label.
    pub to: String,
    /// Latent point in `from`.
    pub x1: Vec<f64>,
    /// Latent point in `to`.
    pub x2: Vec<f64>,
    /// Rig distance of the two poses.
    pub distance: f64,
    /// Where it lands in `to` ([`Library::new`] finds it).
    pub landing: Option<Landing>,
}

/// The models, their training frames (same order) and the bridges.
#[derive(Debug)]
pub struct Library<'a> {
    /// Models.
    pub models: Vec<&'a LatentModel>,
    /// Per model, its training frames.
    pub frames: Vec<Vec<TrainingFrame>>,
    /// Bridges.
    pub links: Vec<Link>,
    /// Per model, its idle dynamics from its training frames (`None`: too few frames, or
    /// no motion; the fixed settings then apply).
    pub dynamics: Vec<Option<Dynamics>>,
}

impl<'a> Library<'a> {
    /// A library: each bridge's landing found in its target model, and each model's idle
    /// [`Dynamics`] calibrated under `set` (see [`crate::method`]).
    pub fn new(
        models: Vec<&'a LatentModel>,
        frames: Vec<Vec<TrainingFrame>>,
        mut links: Vec<Link>,
        set: &Settings,
    ) -> Self {
        let means: Vec<Vec<f64>> = models.iter().map(|m| training_means(m)).collect();
        for l in &mut links {
            if let Some(b) = models.iter().position(|m| m.label == l.to) {
                l.landing = landing(models[b], &means[b], &l.x2);
            }
        }
        let dynamics: Vec<Option<Dynamics>> = models.iter().zip(&frames).map(|(m, f)| calibrate(m, f, set)).collect();
        Self { models, frames, links, dynamics }
    }
}

/// A model's [`Dynamics`]: the closed-form rule, then IDLE simulated from
/// [`crate::method::CALIBRATION_STARTS`] training latents and $\alpha$ scaled until the
/// mean latent speed (after the first half-second) matches the training speed, never above
/// $(\kappa\,\omega_0^2 r)^2$ ([`crate::method::max_random_force`]).
fn calibrate(model: &LatentModel, frames: &[TrainingFrame], set: &Settings) -> Option<Dynamics> {
    use crate::method::{max_random_force, CALIBRATION_ROUNDS, CALIBRATION_SECONDS, CALIBRATION_STARTS};
    let max_variance = max_random_force(set.particle.omega0, set.radius).powi(2);
    let mut dynamics = Dynamics::from_training(frames, set.fps, set.random_gamma)?;
    dynamics.random_variance = dynamics.random_variance.min(max_variance);
    let set = Settings { method: Method { idle: IdleRule::FromData, ..set.method }, ..*set };
    let skip = (0.5 * set.fps).round() as usize;
    let starts: Vec<usize> = (0..CALIBRATION_STARTS).map(|i| i * frames.len() / CALIBRATION_STARTS).collect();
    let mut lib = Library { models: vec![model], frames: vec![frames.to_vec()], links: vec![], dynamics: vec![None] };
    for _ in 0..CALIBRATION_ROUNDS {
        lib.dynamics[0] = Some(dynamics);
        let (mut sum, mut count) = (0.0, 0usize);
        for (i, &s) in starts.iter().enumerate() {
            let start = crate::script::Start {
                label: model.label.clone(),
                segment: None,
                clip: None,
                frame: None,
                latent: Some(frames[s].x.clone()),
            };
            let idle = Command::Idle { duration: CALIBRATION_SECONDS, radius: None, poses: vec![], hover: None };
            let script = Script { name: None, seed: 0x6361_6c69_6272 + i as u64, start, commands: vec![idle] };
            let Ok(out) = run(&lib, &script, &set) else { continue };
            for w in out[skip.min(out.len())..].windows(2) {
                sum += dist(&w[1].x, &w[0].x) * set.fps;
                count += 1;
            }
        }
        let measured = sum / count.max(1) as f64;
        if !(measured > 0.0 && measured.is_finite()) {
            break;
        }
        let factor = (dynamics.training_speed / measured).powi(2).clamp(1.0 / 16.0, 16.0);
        dynamics.random_variance = (dynamics.random_variance * factor).min(max_variance);
    }
    Some(dynamics)
}

/// Engine settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Frames per second.
    pub fps: f64,
    /// The constraint and integrator.
    pub particle: ParticleParams,
    /// Default path radius (latent units).
    pub radius: f64,
    /// Radius while reaching a bridge or a segment start.
    pub tight_radius: f64,
    /// $a$ of Eq. 11.
    pub density_force: f64,
    /// $v$ of Eq. 11 (relative density).
    pub density_threshold: f64,
    /// $l$ of Eq. 11.
    pub density_width: f64,
    /// Random force variance $\alpha$.
    pub random_variance: f64,
    /// Random force squared time scale $\gamma$ (s²).
    pub random_gamma: f64,
    /// Fourier features per component.
    pub random_features: usize,
    /// Linear drag $c$ (s⁻¹).
    pub drag: f64,
    /// Latent speed limit (latent units per second) of every approach; `None`: each
    /// model's own typical speed ([`typical_speed`]) times `speed_factor`.
    pub speed: Option<f64>,
    /// Multiplier of the typical speed when `speed` is `None` (default 1).
    pub speed_factor: f64,
    /// Seconds an approach may take, path and arrival, before it fails.
    pub timeout_seconds: f64,
    /// Default blend length (frames).
    pub blend_frames: usize,
    /// MOVE graph: neighbours per point (0: the paper's complete graph).
    pub graph_k: usize,
    /// Cost $\lVert\Delta\rVert^p$ (or the inverse, see [`EdgeCost`]).
    pub graph_cost: EdgeCost,
    /// The improvements over the paper ([`Method::TUNED`] by default).
    pub method: Method,
}

impl Settings {
    /// The paper's method: every improvement of [`Method`] off.
    pub fn paper() -> Self {
        Self { method: Method::PAPER, ..Self::default() }
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            fps: 24.0,
            particle: ParticleParams::default(),
            radius: 0.25,
            tight_radius: 0.05,
            density_force: 2.0,
            density_threshold: 0.2,
            density_width: 0.05,
            random_variance: 0.25,
            random_gamma: 0.05,
            random_features: 32,
            drag: 2.0,
            speed: None,
            speed_factor: 1.0,
            timeout_seconds: 10.0,
            blend_frames: 12,
            graph_k: 0,
            graph_cost: EdgeCost::Power(4.0),
            method: Method::TUNED,
        }
    }
}

/// What the particle is doing in a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Phase {
    /// Going to a point: a MOVE's target, an IDLE pose, a bridge, a segment's first frame.
    Reach,
    /// Hovering about a point.
    #[default]
    Idle,
    /// A TRANSITION's rig-space blend of two models.
    Blend,
    /// Playing a training segment.
    Play,
}

impl Phase {
    /// Its name, lower case.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Reach => "reach",
            Phase::Idle => "idle",
            Phase::Blend => "blend",
            Phase::Play => "play",
        }
    }
}

/// One synthesized frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Frame index from 0.
    pub frame: usize,
    /// Seconds.
    pub time: f64,
    /// Index of the model in the library (during a transition's blend, the model blended
    /// into).
    pub model: usize,
    /// Latent point (of that model's particle).
    pub x: Vec<f64>,
    /// Rig controls (blended across switches).
    pub controls: Vec<f64>,
    /// The command (index in the script) that produced it.
    pub command: usize,
    /// What the particle was doing.
    pub phase: Phase,
    /// The bridge's $x_1$ the particle heads for (while a TRANSITION reaches and blends).
    pub aim: Option<Vec<f64>>,
}

/// Where synthesis stands after a frame: enough to resume it there ([`Synth::resume`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Frames produced so far (the next frame's index; the random force's clock).
    pub frame: usize,
    /// The current model.
    pub model: usize,
    /// The particle's position.
    pub x: Vec<f64>,
    /// Its velocity.
    pub v: Vec<f64>,
    /// The path point it follows.
    pub target: Vec<f64>,
}

/// Where a [`Synth`]'s frames go: each frame with the checkpoint after it; `false` stops
/// the synthesis ([`SynthError::Stopped`]).
pub type Sink<'s> = dyn FnMut(Frame, Checkpoint) -> bool + 's;

/// The median latent speed of a model's training data (latent units per second):
/// $\operatorname{median}\lVert x_{t+1} - x_t\rVert\cdot\text{fps}$ over consecutive frames of
/// each segment; `None` without two consecutive frames.
pub fn typical_speed(frames: &[TrainingFrame], fps: f64) -> Option<f64> {
    let mut order: Vec<&TrainingFrame> = frames.iter().collect();
    order.sort_by_key(|f| (f.segment, f.frame));
    let mut steps: Vec<f64> = order
        .windows(2)
        .filter(|w| w[0].segment == w[1].segment && w[1].frame == w[0].frame + 1)
        .map(|w| dist(&w[0].x, &w[1].x) * fps)
        .collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(steps[steps.len() / 2])
}

/// One particle in one model: where it is, and the path point it follows.
#[derive(Debug, Clone)]
struct Stream {
    model: usize,
    state: State,
    target: Vec<f64>,
}

/// Arrival tolerance on the radius: the critically damped constraint brings a particle
/// from outside onto the rim, $\lVert x - p\rVert \to r$, only asymptotically.
const ARRIVAL_SLACK: f64 = 1.1;

/// The incoming stream of a blend reads the random force this many seconds later, so the
/// two particles do not jitter in lockstep.
const INCOMING_TIME_OFFSET: f64 = 1000.0;

/// A synthesis in progress: the library, the particle and the random force, producing
/// frames one command at a time into a sink. [`run`] runs a whole script; a live session
/// executes commands as they come and resumes from a [`Checkpoint`].
pub struct Synth<'l, 'a> {
    lib: &'l Library<'a>,
    set: Settings,
    /// Speed limit per model (latent units per second).
    speed: Vec<f64>,
    cur: Stream,
    /// Frames produced so far.
    done: usize,
    random: RandomForce,
    command: usize,
    phase: Phase,
    aim: Option<Vec<f64>>,
}

impl std::fmt::Debug for Synth<'_, '_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Synth").field("checkpoint", &self.checkpoint()).finish_non_exhaustive()
    }
}

impl<'l, 'a> Synth<'l, 'a> {
    /// A synthesis at the start pose of `start` (at rest, frame 0), the random force drawn
    /// from `seed`.
    ///
    /// # Errors
    /// [`SynthError::UnknownLabel`], [`SynthError::BadPose`].
    pub fn new(
        lib: &'l Library<'a>,
        set: &Settings,
        start: &crate::script::Start,
        seed: u64,
    ) -> Result<Self, SynthError> {
        let q = lib.models.first().map_or(0, |m| m.q());
        let mut s = Self::blank(lib, set, seed, q);
        s.cur.model = s.model_index(&start.label)?;
        let x0 = s.resolve(&start.pose())?;
        s.cur.state = State::at_rest(&x0);
        s.cur.target = x0;
        Ok(s)
    }

    /// A synthesis resumed at `cp` (the random force drawn from `seed` and read from the
    /// checkpoint's frame on): the same frames as the synthesis that made the checkpoint
    /// would have produced from there, given the same commands.
    ///
    /// # Errors
    /// [`SynthError::BadCheckpoint`] if its model or dimensions do not fit the library.
    pub fn resume(lib: &'l Library<'a>, set: &Settings, seed: u64, cp: &Checkpoint) -> Result<Self, SynthError> {
        let q = lib.models.first().map_or(0, |m| m.q());
        let bad = SynthError::BadCheckpoint { model: cp.model, q: cp.x.len() };
        if cp.model >= lib.models.len() || [&cp.x, &cp.v, &cp.target].iter().any(|v| v.len() != q) {
            return Err(bad);
        }
        let mut s = Self::blank(lib, set, seed, q);
        s.cur =
            Stream { model: cp.model, state: State { x: cp.x.clone(), v: cp.v.clone() }, target: cp.target.clone() };
        s.done = cp.frame;
        Ok(s)
    }

    fn blank(lib: &'l Library<'a>, set: &Settings, seed: u64, q: usize) -> Self {
        let speed = lib
            .frames
            .iter()
            .map(|f| set.speed.or_else(|| typical_speed(f, set.fps).map(|v| v * set.speed_factor)).unwrap_or(1.0))
            .collect();
        Self {
            lib,
            set: *set,
            speed,
            cur: Stream { model: 0, state: State::at_rest(&vec![0.0; q]), target: vec![0.0; q] },
            done: 0,
            random: RandomForce::new(q, 1.0, set.random_gamma, set.random_features, seed),
            command: 0,
            phase: Phase::Idle,
            aim: None,
        }
    }

    /// Where it stands now.
    pub fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            frame: self.done,
            model: self.cur.model,
            x: self.cur.state.x.clone(),
            v: self.cur.state.v.clone(),
            target: self.cur.target.clone(),
        }
    }

    /// Runs command `c` (its frames numbered as command `index`) from where the synthesis
    /// stands, each frame into `sink`.
    ///
    /// # Errors
    /// As the command fails ([`SynthError`]); [`SynthError::Stopped`] when the sink says
    /// stop. The synthesis then stands where the last frame left it.
    pub fn execute(&mut self, index: usize, c: &Command, sink: &mut Sink<'_>) -> Result<(), SynthError> {
        self.command = index;
        self.aim = None;
        self.execute_command(c, sink)
    }

    fn label(&self) -> &str {
        &self.lib.models[self.cur.model].label
    }

    fn model_index(&self, label: &str) -> Result<usize, SynthError> {
        self.lib.models.iter().position(|m| m.label == label).ok_or_else(|| SynthError::UnknownLabel {
            label: label.into(),
            known: self.lib.models.iter().map(|m| m.label.as_str()).collect::<Vec<_>>().join(", "),
        })
    }

    fn resolve(&self, pose: &Pose) -> Result<Vec<f64>, SynthError> {
        let bad = |what: String| SynthError::BadPose { label: self.label().into(), what };
        let q = self.lib.models[self.cur.model].q();
        if let Some(x) = &pose.latent {
            if x.len() != q || x.iter().any(|v| !v.is_finite()) {
                return Err(bad(format!("a latent pose needs {q} finite values, got {x:?}")));
            }
            return Ok(x.clone());
        }
        let frame =
            pose.frame.ok_or_else(|| bad("a pose needs `frame` (with `segment` or `clip`) or `latent`".into()))?;
        self.lib.frames[self.cur.model]
            .iter()
            .find(|f| {
                f.frame == frame
                    && pose.segment.is_none_or(|s| s == f.segment)
                    && pose.clip.as_ref().is_none_or(|c| c == &f.clip)
            })
            .map(|f| f.x.clone())
            .ok_or_else(|| {
                bad(format!(
                    "no training frame {frame} of {}",
                    crate::script::segment_or_clip(pose.segment, pose.clip.as_deref())
                ))
            })
    }

    /// Model `model`'s random-force variance and drag under the method's idle rule.
    fn dynamics(&self, model: usize) -> (f64, f64) {
        match (self.set.method.idle, self.lib.dynamics.get(model).copied().flatten()) {
            (IdleRule::FromData, Some(d)) => (d.random_variance, d.drag),
            _ => (self.set.random_variance, self.set.drag),
        }
    }

    fn controls(&self, model: usize, x: &[f64]) -> Vec<f64> {
        let m = self.lib.models[model];
        let mut p = vec![0.0; m.controls()];
        m.controls_into(x, &mut vec![0.0; m.d()], &mut p);
        p
    }

    /// Steps `stream` one frame toward the path point `next` with radius `r`, reading the
    /// random force `time_offset` seconds later; returns its rig controls.
    fn step(&self, stream: &mut Stream, next: &[f64], r: f64, time_offset: f64) -> Vec<f64> {
        let m = self.lib.models[stream.model];
        let set = self.set;
        let dt = 1.0 / set.fps;
        let t0 = self.done as f64 * dt;
        let random = &self.random;
        let (alpha, drag) = self.dynamics(stream.model);
        let amplitude = match set.method.idle {
            IdleRule::FromData => alpha.max(0.0).sqrt().min(crate::method::max_random_force(set.particle.omega0, r)),
            IdleRule::Fixed => alpha.max(0.0).sqrt(),
        };
        let mut grad = vec![0.0; m.q()];
        let mut rf = vec![0.0; m.q()];
        let mut force = |x: &[f64], v: &[f64], t: f64, out: &mut [f64]| {
            let p = m.density.relative(x, &mut grad);
            let norm = grad.iter().map(|g| g * g).sum::<f64>().sqrt();
            let s = set.density_force / (1.0 + ((p - set.density_threshold) / set.density_width).exp());
            random.at(t + time_offset, &mut rf);
            for k in 0..out.len() {
                let dens = if norm > 1e-300 && s.is_finite() { s * grad[k] / norm } else { 0.0 };
                out[k] = dens + amplitude * rf[k] - drag * v[k];
            }
        };
        let prev = std::mem::replace(&mut stream.target, next.to_vec());
        step_frame(&set.particle, &mut stream.state, Leg { t0, dt, from: &prev, to: next, radius: r }, &mut force);
        self.controls(stream.model, &stream.state.x)
    }

    fn push(&mut self, controls: Vec<f64>, sink: &mut Sink<'_>) -> Result<(), SynthError> {
        let dt = 1.0 / self.set.fps;
        let frame = Frame {
            frame: self.done,
            time: (self.done + 1) as f64 * dt,
            model: self.cur.model,
            x: self.cur.state.x.clone(),
            controls,
            command: self.command,
            phase: self.phase,
            aim: self.aim.clone(),
        };
        self.done += 1;
        if sink(frame, self.checkpoint()) {
            Ok(())
        } else {
            Err(SynthError::Stopped)
        }
    }

    /// Steps the current particle one frame toward `next` and records it.
    fn frame(&mut self, next: &[f64], r: f64, sink: &mut Sink<'_>) -> Result<(), SynthError> {
        let mut cur = self.cur.clone();
        let controls = self.step(&mut cur, next, r, 0.0);
        self.cur = cur;
        self.push(controls, sink)
    }

    fn frames_for(&self, seconds: f64) -> usize {
        ((seconds * self.set.fps).round() as usize).max(1)
    }

    /// The path point's step per frame: the speed limit, or slower when `min_seconds`
    /// asks the polyline to take at least that long.
    fn step_length(&self, length: f64, min_seconds: Option<f64>) -> f64 {
        let limit = self.speed[self.cur.model] / self.set.fps;
        match min_seconds {
            Some(s) if s > 0.0 => limit.min(length / (s * self.set.fps)),
            _ => limit,
        }
    }

    /// Lays the path point along `poly` at the speed limit (or slower, see
    /// [`Synth::step_length`]) with radius `r`, then waits for the particle to arrive within
    /// `r` of the end, moving no faster than the limit; errs after `timeout_seconds`.
    fn approach(
        &mut self,
        poly: &[Vec<f64>],
        r: f64,
        min_seconds: Option<f64>,
        what: &str,
        sink: &mut Sink<'_>,
    ) -> Result<(), SynthError> {
        let length: f64 = poly.windows(2).map(|w| dist(&w[0], &w[1])).sum();
        let step = self.step_length(length, min_seconds).max(1e-12);
        // A disc smaller than one frame's travel of the path point makes the constraint
        // stiff enough to throw the particle out (measured: it diverged at 0.05 against a
        // 0.13 step); the radius, constraint and arrival alike, is at least that step.
        let r = r.max(self.speed[self.cur.model] / self.set.fps);
        let frames = (length / step).ceil() as usize;
        let budget = self.frames_for(self.set.timeout_seconds);
        let end = poly.last().cloned().unwrap_or_else(|| self.cur.target.clone());
        let fail = |run: &Self| SynthError::Timeout {
            label: run.label().into(),
            what: what.into(),
            seconds: run.set.timeout_seconds,
            distance: dist(&run.cur.state.x, &end),
            radius: r,
        };
        if frames > budget {
            return Err(fail(self));
        }
        if frames > 0 {
            for p in resample(poly, frames) {
                self.frame(&p, r, sink)?;
            }
        }
        let limit = self.speed[self.cur.model];
        let mut spent = frames;
        while !(dist(&self.cur.state.x, &end) <= ARRIVAL_SLACK * r && norm(&self.cur.state.v) <= limit) {
            if !self.cur.state.x.iter().chain(&self.cur.state.v).all(|v| v.is_finite()) {
                return Err(SynthError::Diverged { label: self.label().into(), what: what.into() });
            }
            if spent >= budget {
                return Err(fail(self));
            }
            self.frame(&end, r, sink)?;
            spent += 1;
        }
        Ok(())
    }

    fn go(
        &mut self,
        to: &[f64],
        kind: PathKind,
        r: f64,
        min_seconds: Option<f64>,
        what: &str,
        sink: &mut Sink<'_>,
    ) -> Result<(), SynthError> {
        let m = self.lib.models[self.cur.model];
        let from = self.cur.target.clone();
        let poly = match kind {
            PathKind::Straight => vec![from, to.to_vec()],
            PathKind::Graph => graph_path(m.latents(), m.q(), &from, to, self.set.graph_k, self.set.graph_cost),
        };
        self.approach(&poly, r, min_seconds, what, sink)
    }

    fn hold(&mut self, at: &[f64], frames: usize, r: f64, sink: &mut Sink<'_>) -> Result<(), SynthError> {
        for _ in 0..frames {
            self.frame(at, r, sink)?;
        }
        Ok(())
    }

    /// The bridge from the current model to model `to` the method chooses: the nearest
    /// $x_1$, or the least travel-plus-landing time (see [`crate::method`]).
    fn best_link(&self, to: usize) -> Option<&Link> {
        let (from, target) = (self.label(), self.lib.models[to].label.as_str());
        let x = &self.cur.state.x;
        let cost = |l: &Link| match self.set.method.bridge_choice {
            BridgeChoice::Nearest => dist(&l.x1, x),
            BridgeChoice::TravelAndLanding => {
                let land = l.landing.as_ref().map_or(0.0, |g| g.latent_distance);
                dist(&l.x1, x) / self.speed[self.cur.model] + land / self.speed[to]
            }
        };
        self.lib.links.iter().filter(|l| l.from == from && l.to == target).min_by(|a, b| cost(a).total_cmp(&cost(b)))
    }

    /// Reach the chosen bridge to `to`, then blend the two live streams over `blend`
    /// frames while both particles idle at the bridge's ends; returns the bridge.
    fn switch(&mut self, to: usize, blend: usize, sink: &mut Sink<'_>) -> Result<Link, SynthError> {
        let (from, target) = (self.label().to_string(), self.lib.models[to].label.clone());
        let link = self.best_link(to).cloned().ok_or(SynthError::NoBridge { from, to: target.clone() })?;
        let r = self.set.tight_radius;
        (self.phase, self.aim) = (Phase::Reach, Some(link.x1.clone()));
        self.go(&link.x1, PathKind::Straight, r, None, &format!("the bridge to `{target}`"), sink)?;
        self.phase = Phase::Blend;
        let mut old = self.cur.clone();
        let mut new = Stream { model: to, state: State::at_rest(&link.x2), target: link.x2.clone() };
        let (ra, rb) = (r.max(self.speed[old.model] / self.set.fps), r.max(self.speed[to] / self.set.fps));
        for f in 0..blend {
            let a = self.step(&mut old, &link.x1, ra, 0.0);
            let b = self.step(&mut new, &link.x2, rb, INCOMING_TIME_OFFSET);
            let s = (f + 1) as f64 / blend as f64;
            let w = s * s * (3.0 - 2.0 * s);
            self.cur = new.clone();
            self.push(a.iter().zip(&b).map(|(a, b)| (1.0 - w) * a + w * b).collect(), sink)?;
        }
        self.cur = new;
        self.aim = None;
        Ok(link)
    }

    /// The route to `to`: direct, or through the third label with the closest bridges.
    fn route(&self, to: usize) -> Result<Vec<usize>, SynthError> {
        let (a, b) = (self.label(), self.lib.models[to].label.as_str());
        let has = |x: &str, y: &str| self.lib.links.iter().any(|l| l.from == x && l.to == y);
        if has(a, b) {
            return Ok(vec![to]);
        }
        let best = |x: &str, y: &str| {
            self.lib.links.iter().filter(|l| l.from == x && l.to == y).map(|l| l.distance).fold(f64::INFINITY, f64::min)
        };
        (0..self.lib.models.len())
            .filter(|&c| c != self.cur.model && c != to)
            .map(|c| {
                let cl = self.lib.models[c].label.as_str();
                (best(a, cl) + best(cl, b), c)
            })
            .filter(|(d, _)| d.is_finite())
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .map(|(_, c)| vec![c, to])
            .ok_or(SynthError::NoBridge { from: a.into(), to: b.into() })
    }

    fn execute_command(&mut self, c: &Command, sink: &mut Sink<'_>) -> Result<(), SynthError> {
        match c {
            Command::Idle { duration, radius, poses, hover } => {
                let r = radius.unwrap_or(self.set.radius);
                let total = self.frames_for(*duration);
                let points: Vec<Vec<f64>> = if poses.is_empty() {
                    vec![self.cur.target.clone()]
                } else {
                    poses.iter().map(|p| self.resolve(p)).collect::<Result<_, _>>()?
                };
                let per = hover.map_or(total.div_ceil(points.len()), |h| self.frames_for(h));
                let start = self.done;
                for p in points.iter().cycle() {
                    let done = self.done - start;
                    if done >= total {
                        break;
                    }
                    if dist(p, &self.cur.target) > 1e-12 {
                        self.phase = Phase::Reach;
                        self.go(p, PathKind::Straight, r, None, "an idle pose", sink)?;
                    }
                    let done = self.done - start;
                    self.phase = Phase::Idle;
                    self.hold(p, per.min(total.saturating_sub(done)).max(1), r, sink)?;
                }
            }
            Command::Move { to, duration, path, radius } => {
                let x = self.resolve(to)?;
                let r = radius.unwrap_or(self.set.radius);
                self.phase = Phase::Reach;
                self.go(&x, *path, r, Some(*duration), "the move's target", sink)?;
            }
            Command::Transition { to, blend_frames } => {
                let to = self.model_index(to)?;
                if to != self.cur.model {
                    let mut last = None;
                    for hop in self.route(to)? {
                        last = Some(self.switch(hop, blend_frames.unwrap_or(self.set.blend_frames).max(1), sink)?);
                    }
                    if let Some(landing) = last.and_then(|l| l.landing).filter(|_| self.set.method.settle) {
                        let what = "the target label's training pose nearest the landing";
                        self.phase = Phase::Reach;
                        self.go(&landing.x, PathKind::Straight, self.set.radius, None, what, sink)?;
                    }
                }
            }
            Command::Play { segment, clip } => {
                let label = self.label().to_string();
                let frames: Vec<&TrainingFrame> = self.lib.frames[self.cur.model]
                    .iter()
                    .filter(|f| segment.is_none_or(|s| s == f.segment) && clip.as_ref().is_none_or(|c| c == &f.clip))
                    .collect();
                let Some(first) = frames.iter().min_by_key(|f| (f.segment, f.frame)) else {
                    return Err(SynthError::BadPose {
                        label,
                        what: format!(
                            "no {} to play in this label",
                            crate::script::segment_or_clip(*segment, clip.as_deref())
                        ),
                    });
                };
                let seg = first.segment;
                let mut seq: Vec<&TrainingFrame> = frames.iter().copied().filter(|f| f.segment == seg).collect();
                seq.sort_by_key(|f| f.frame);
                let xs: Vec<Vec<f64>> = seq.iter().map(|f| f.x.clone()).collect();
                self.phase = Phase::Reach;
                self.go(&xs[0], PathKind::Straight, self.set.tight_radius, None, "the segment's first frame", sink)?;
                self.phase = Phase::Play;
                // Play the embedding itself, one training frame per output frame: the
                // particle is carried along it (position and velocity), not pulled by the
                // constraint — a disc small enough to track the embedding is outrun by its
                // fast frames, and the constraint keeps the tangential velocity each jump of
                // ṗ gives it, until RK4 diverges (measured on dragon-face v2).
                let fps = self.set.fps;
                for w in xs.windows(2) {
                    let v: Vec<f64> = w[1].iter().zip(&w[0]).map(|(b, a)| (b - a) * fps).collect();
                    self.cur.state = State { x: w[1].clone(), v };
                    self.cur.target = w[1].clone();
                    let controls = self.controls(self.cur.model, &w[1]);
                    self.push(controls, sink)?;
                }
            }
        }
        Ok(())
    }
}

/// Runs a script: one frame per $1/\text{fps}$ seconds from its start pose.
pub fn run(lib: &Library<'_>, script: &Script, set: &Settings) -> Result<Vec<Frame>, SynthError> {
    let mut synth = Synth::new(lib, set, &script.start, script.seed)?;
    let mut out = Vec::new();
    let mut sink = |f: Frame, _: Checkpoint| {
        out.push(f);
        true
    };
    for (i, c) in script.commands.iter().enumerate() {
        synth.execute(i, c, &mut sink)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::script::Start;
    use reprise_numerics::gplvm::{Hyper, LikelihoodConfig, Predictor, RigMap};

    /// A model over 40 latent points along an arc (two segments of 20), outputs a smooth
    /// function of the latent, mapped to 3 controls (identity PCA, unit weights) plus an offset.
    fn model(label: &str, shift: f64) -> (LatentModel, Vec<TrainingFrame>) {
        let (n, d) = (40, 3);
        let x: Vec<f64> = (0..n).flat_map(|i| [(i as f64 * 0.08).cos() * 1.5, (i as f64 * 0.08).sin() * 1.5]).collect();
        let y: Vec<f64> = (0..n)
            .flat_map(|i| {
                let (a, b) = (x[2 * i], x[2 * i + 1]);
                [a.sin() + shift, (a * b).cos() - 0.5, b + 0.3 * shift]
            })
            .collect();
        let hyper = Hyper { rbf_variance: 1.0, lengthscale: 0.6, white_variance: 1e-4 };
        let pred = Predictor::new(&x, &y, d, hyper, &LikelihoodConfig::default()).unwrap();
        let eye = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let map = RigMap::from_pca(&[0.0; 3], &eye, &[0.0; 3], &[1.0; 3]).unwrap();
        let frames = (0..n)
            .map(|i| TrainingFrame {
                segment: (i / 20) as i64,
                clip: format!("{label}_c{}", i / 20),
                frame: (i % 20) as i64,
                x: x[2 * i..2 * i + 2].to_vec(),
            })
            .collect();
        (LatentModel::new(label.into(), pred, x.clone(), vec![0.0; 3], map).unwrap(), frames)
    }

    fn script(commands: Vec<Command>, seed: u64) -> Script {
        let start = Start { label: "a".into(), segment: Some(0), clip: None, frame: Some(0), latent: None };
        Script { name: None, seed, start, commands }
    }

    fn with_lib<R>(links: Vec<Link>, f: impl FnOnce(&Library<'_>) -> R) -> R {
        let (a, fa) = model("a", 0.0);
        let (b, fb) = model("b", 0.7);
        let (c, fc) = model("c", -0.4);
        let lib = Library::new(vec![&a, &b, &c], vec![fa, fb, fc], links, &Settings::paper());
        f(&lib)
    }

    fn link(from: &str, to: &str, x1: [f64; 2], x2: [f64; 2]) -> Link {
        Link { from: from.into(), to: to.into(), x1: x1.to_vec(), x2: x2.to_vec(), distance: 0.1, landing: None }
    }

    /// The same seed gives identical frames; another seed differs.
    #[test]
    fn deterministic_per_seed() {
        let cmds = vec![Command::Idle { duration: 2.0, radius: Some(0.3), poses: vec![], hover: None }];
        with_lib(vec![], |lib| {
            let s = Settings::paper();
            let a = run(lib, &script(cmds.clone(), 4), &s).unwrap();
            let b = run(lib, &script(cmds.clone(), 4), &s).unwrap();
            let c = run(lib, &script(cmds, 5), &s).unwrap();
            assert_eq!(a, b);
            assert_ne!(a, c);
            assert_eq!(a.len(), 48);
        });
    }

    /// Stopping a synthesis after any frame and resuming from that frame's checkpoint with
    /// the rest of the work gives the frames the uninterrupted run gives, bit for bit (the
    /// random force reads the checkpoint's clock); a stopped sink stops it, and a
    /// checkpoint for another library is refused.
    #[test]
    fn a_synthesis_resumed_from_a_checkpoint_goes_on_as_if_never_stopped() {
        let links = vec![link("a", "b", [0.8, 1.27], [0.8, 1.27])];
        let idle =
            |frames: usize| Command::Idle { duration: frames as f64 / 24.0, radius: None, poses: vec![], hover: None };
        with_lib(links, |lib| {
            let set = Settings::default();
            let start = script(vec![], 9).start;
            let whole =
                run(lib, &script(vec![idle(30), Command::Transition { to: "b".into(), blend_frames: None }], 9), &set)
                    .unwrap();
            assert!(whole.iter().any(|f| f.phase == Phase::Blend && f.aim.is_some()), "phases are marked");
            for stop in [1, 7, 29] {
                let mut synth = Synth::new(lib, &set, &start, 9).unwrap();
                let (mut got, mut at) = (Vec::new(), None);
                let mut sink = |f: Frame, cp: Checkpoint| {
                    got.push(f);
                    at = Some(cp);
                    got.len() < stop
                };
                assert_eq!(synth.execute(0, &idle(30), &mut sink), Err(SynthError::Stopped));
                let cp = at.unwrap();
                assert_eq!(cp.frame, stop);
                let mut resumed = Synth::resume(lib, &set, 9, &cp).unwrap();
                let mut sink = |f: Frame, _: Checkpoint| {
                    got.push(f);
                    true
                };
                resumed.execute(0, &idle(30 - stop), &mut sink).unwrap();
                resumed.execute(1, &Command::Transition { to: "b".into(), blend_frames: None }, &mut sink).unwrap();
                assert_eq!(got, whole, "stopped after {stop} frames");
            }
            let cp = Checkpoint { frame: 0, model: 5, x: vec![0.0; 2], v: vec![0.0; 2], target: vec![0.0; 2] };
            assert!(matches!(Synth::resume(lib, &set, 9, &cp), Err(SynthError::BadCheckpoint { .. })));
            let cp = Checkpoint { model: 0, x: vec![0.0; 3], ..cp };
            assert!(matches!(Synth::resume(lib, &set, 9, &cp), Err(SynthError::BadCheckpoint { .. })));
        });
    }

    /// IDLE about a fixed pose keeps the particle within (about) r of it after settling.
    #[test]
    fn idle_stays_near_its_pose() {
        let cmds = vec![Command::Idle { duration: 4.0, radius: Some(0.2), poses: vec![], hover: None }];
        with_lib(vec![], |lib| {
            let out = run(lib, &script(cmds, 1), &Settings::paper()).unwrap();
            let x0 = [1.5, 0.0];
            let worst = out[24..].iter().map(|f| dist(&f.x, &x0)).fold(0.0, f64::max);
            assert!(worst < 0.2 * 1.25, "strays {worst}");
        });
    }

    /// TRANSITION reaches the bridge, switches model there, and the blended controls have
    /// no jump: the largest frame-to-frame change across the switch is no larger than
    /// elsewhere in the run (times a small factor).
    #[test]
    fn transition_switches_at_a_bridge_continuously() {
        let links = vec![link("a", "b", [0.8, 1.27], [0.8, 1.27])];
        let cmds = vec![
            Command::Idle { duration: 1.0, radius: None, poses: vec![], hover: None },
            Command::Transition { to: "b".into(), blend_frames: Some(12) },
            Command::Idle { duration: 1.0, radius: None, poses: vec![], hover: None },
        ];
        with_lib(links, |lib| {
            let out = run(lib, &script(cmds, 2), &Settings::paper()).unwrap();
            let sw = out.iter().position(|f| f.model == 1).expect("switched");
            assert!(out[..sw].iter().all(|f| f.model == 0) && out[sw..].iter().all(|f| f.model == 1));
            let arrival =
                ARRIVAL_SLACK * Settings::paper().tight_radius.max(typical_speed(&lib.frames[0], 24.0).unwrap() / 24.0);
            assert!(dist(&out[sw - 1].x, &[0.8, 1.27]) <= arrival, "switches at the bridge: {:?}", out[sw - 1].x);
            let step = |i: usize| dist(&out[i].controls, &out[i - 1].controls);
            let across = (sw..sw + 12).map(step).fold(0.0, f64::max);
            // Without the blend the switch would jump by the offset between the models (≈0.7).
            assert!(across < 0.15, "largest step across the blend {across}");
        });
    }

    /// Frames from the TRANSITION command to the first frame of the target model.
    fn latency(out: &[Frame], command: usize, to: usize) -> usize {
        let start = out.iter().position(|f| f.command == command).expect("the command ran");
        out.iter().position(|f| f.model == to).expect("switched") - start + 1
    }

    /// With a fixed speed limit, a bridge farther from the particle takes longer to reach:
    /// the latency grows with the latent distance (by about distance / speed).
    #[test]
    fn latency_grows_with_the_distance_to_the_bridge() {
        let set = Settings { speed: Some(1.0), random_variance: 0.0, ..Settings::paper() };
        let cmds = vec![Command::Transition { to: "b".into(), blend_frames: Some(12) }];
        // The start frame is at (1.5, 0); bridges at growing distances along the arc.
        let mut last = 0;
        for (i, k) in [5usize, 12, 20, 30].into_iter().enumerate() {
            let a = k as f64 * 0.08;
            let x1 = [a.cos() * 1.5, a.sin() * 1.5];
            let d = dist(&x1, &[1.5, 0.0]);
            let lat = with_lib(vec![link("a", "b", x1, x1)], |lib| {
                latency(&run(lib, &script(cmds.clone(), 0), &set).unwrap(), 0, 1)
            });
            let expect = d * 24.0;
            assert!(lat as f64 >= expect && (lat as f64) < expect + 24.0, "bridge {d:.2} away: {lat} frames");
            if i > 0 {
                assert!(lat > last, "{lat} after {last}");
            }
            last = lat;
        }
        // Twice the speed: the travel halves, the settling on arrival stays.
        let x1 = [(30.0f64 * 0.08).cos() * 1.5, (30.0f64 * 0.08).sin() * 1.5];
        let fast = with_lib(vec![link("a", "b", x1, x1)], |lib| {
            latency(&run(lib, &script(cmds.clone(), 0), &Settings { speed: Some(2.0), ..set }).unwrap(), 0, 1)
        });
        assert!((fast as f64) < 0.8 * last as f64, "{fast} vs {last}");
    }

    /// The model switches only once the particle is within the tight radius of the bridge
    /// and no faster than the speed limit — with the random force on.
    #[test]
    fn the_switch_happens_on_arrival() {
        let set = Settings { speed: Some(1.5), ..Settings::paper() };
        let cmds = vec![Command::Transition { to: "b".into(), blend_frames: Some(12) }];
        for seed in 0..8 {
            let x1 = [(25.0f64 * 0.08).cos() * 1.5, (25.0f64 * 0.08).sin() * 1.5];
            let out =
                with_lib(vec![link("a", "b", x1, x1)], |lib| run(lib, &script(cmds.clone(), seed), &set).unwrap());
            let sw = out.iter().position(|f| f.model == 1).unwrap();
            let before = &out[sw - 1];
            // The arrival radius: the tight radius, or one frame of travel if that is larger.
            let r = ARRIVAL_SLACK * set.tight_radius.max(1.5 / set.fps);
            assert!(dist(&before.x, &x1) <= r, "seed {seed}: switched {} away", dist(&before.x, &x1));
            let speed = dist(&out[sw - 1].x, &out[sw - 2].x) * set.fps;
            assert!(speed <= 1.5 * 1.2, "seed {seed}: arrived at {speed} latent units/s");
        }
    }

    /// The blend runs between two live streams: the output is continuous in position and
    /// velocity across it (no step, no kink) — a hard switch between the models would jump
    /// by their offset (≈ 0.7), and a blend from a frozen pose would kink its velocity.
    #[test]
    fn the_blend_is_smooth_between_live_streams() {
        let set = Settings { speed: Some(1.5), ..Settings::paper() };
        let x1 = [0.8, 1.27];
        let cmds = vec![
            Command::Idle { duration: 0.5, radius: None, poses: vec![], hover: None },
            Command::Transition { to: "b".into(), blend_frames: Some(12) },
            Command::Idle { duration: 1.0, radius: None, poses: vec![], hover: None },
        ];
        for seed in 0..6 {
            let out =
                with_lib(vec![link("a", "b", x1, x1)], |lib| run(lib, &script(cmds.clone(), seed), &set).unwrap());
            let sw = out.iter().position(|f| f.model == 1).unwrap();
            let vel = |i: usize| -> Vec<f64> {
                out[i].controls.iter().zip(&out[i - 1].controls).map(|(a, b)| a - b).collect()
            };
            let acc = |i: usize| dist(&vel(i + 1), &vel(i));
            let across = (sw - 1..sw + 13).map(acc).fold(0.0, f64::max);
            let elsewhere = (2..sw - 2).chain(sw + 14..out.len() - 1).map(acc).fold(0.0, f64::max);
            let step = (sw..sw + 12).map(|i| norm(&vel(i))).fold(0.0, f64::max);
            assert!(step < 0.12, "seed {seed}: largest step across the blend {step}");
            assert!(
                across < elsewhere + 0.05,
                "seed {seed}: acceleration {across} across the blend, {elsewhere} elsewhere"
            );
        }
        // The outgoing stream is live: what the blend took from it, (p − w g_b(x_b)) / (1 − w),
        // keeps moving during the blend (a frozen last pose would make it constant).
        let long = vec![Command::Transition { to: "b".into(), blend_frames: Some(24) }];
        with_lib(vec![link("a", "b", x1, x1)], |lib| {
            let out = run(lib, &script(long, 1), &Settings { random_variance: 4.0, ..set }).unwrap();
            let sw = out.iter().position(|f| f.model == 1).unwrap();
            let mut g = vec![0.0; 3];
            let outgoing: Vec<Vec<f64>> = (0..16)
                .map(|f| {
                    let s = (f + 1) as f64 / 24.0;
                    let w = s * s * (3.0 - 2.0 * s);
                    lib.models[1].controls_into(&out[sw + f].x, &mut [0.0; 3], &mut g);
                    out[sw + f].controls.iter().zip(&g).map(|(p, b)| (p - w * b) / (1.0 - w)).collect()
                })
                .collect();
            let moved = outgoing.iter().map(|a| dist(a, &outgoing[0])).fold(0.0, f64::max);
            assert!(moved > 1e-3, "the outgoing stream moved {moved}");
        });
    }

    /// MOVE lays its path at the speed limit: through the training graph (along the arc)
    /// it takes longer than the straight chord; an unreachable target times out clearly.
    #[test]
    fn move_takes_as_long_as_its_path() {
        let set = Settings { speed: Some(1.0), random_variance: 0.0, ..Settings::paper() };
        let to = Pose { segment: Some(1), clip: None, frame: Some(19), latent: None };
        let frames = |path: PathKind| {
            let cmds = vec![Command::Move { to: to.clone(), duration: 0.1, path, radius: Some(0.1) }];
            with_lib(vec![], |lib| run(lib, &script(cmds, 0), &set).unwrap().len())
        };
        let (graph, straight) = (frames(PathKind::Graph), frames(PathKind::Straight));
        // The arc from frame 0 to frame 39 spans 3.12 rad of a 1.5 radius: 4.68 vs a 3.0 chord.
        assert!(graph as f64 > 1.4 * straight as f64, "graph {graph} frames, straight {straight}");
        let far = vec![Command::Move {
            to: Pose { segment: None, clip: None, frame: None, latent: Some(vec![400.0, 0.0]) },
            duration: 1.0,
            path: PathKind::Straight,
            radius: None,
        }];
        let e = with_lib(vec![], |lib| run(lib, &script(far, 0), &set).unwrap_err());
        assert!(matches!(e, SynthError::Timeout { .. }), "{e}");
        assert!(e.to_string().contains("not reached within 10 s"), "{e}");
    }

    /// The default speed limit is the model's own typical training speed.
    #[test]
    fn typical_speed_is_the_median_training_step() {
        with_lib(vec![], |lib| {
            // Consecutive arc points are 0.08 rad apart on a radius of 1.5: 0.12 per frame.
            let v = typical_speed(&lib.frames[0], 24.0).unwrap();
            assert!((v - 2.0 * 1.5 * (0.04f64).sin() * 24.0).abs() < 1e-9, "{v}");
        });
        assert_eq!(typical_speed(&[], 24.0), None);
    }

    /// No direct bridge: the route goes through the third label; with none, a clear error.
    #[test]
    fn transition_routes_through_a_third_label() {
        let links = vec![link("a", "c", [1.5, 0.0], [1.5, 0.0]), link("c", "b", [1.0, 1.1], [1.0, 1.1])];
        let cmds = vec![Command::Transition { to: "b".into(), blend_frames: None }];
        with_lib(links, |lib| {
            let out = run(lib, &script(cmds.clone(), 0), &Settings::paper()).unwrap();
            let models: Vec<usize> = out.iter().map(|f| f.model).collect();
            assert!(models.contains(&2) && models.last() == Some(&1), "{models:?}");
        });
        with_lib(vec![], |lib| {
            let e = run(lib, &script(cmds, 0), &Settings::paper()).unwrap_err();
            assert_eq!(e, SynthError::NoBridge { from: "a".into(), to: "b".into() });
            let bad = vec![Command::Transition { to: "zzz".into(), blend_frames: None }];
            assert!(run(lib, &script(bad, 0), &Settings::paper()).unwrap_err().to_string().contains("a, b, c"));
        });
    }

    /// Mean latent speed of frames `from..` (latent units per second).
    fn mean_speed(out: &[Frame], from: usize) -> f64 {
        let w: Vec<f64> = out[from..].windows(2).map(|w| dist(&w[1].x, &w[0].x) * 24.0).collect();
        w.iter().sum::<f64>() / w.len() as f64
    }

    /// With `live-idle` the idling particle moves about as fast as the label's training
    /// frames (0.12 latent units a frame here, 2.9 /s) over several seeds; the paper's fixed
    /// force and drag leave it far slower.
    #[test]
    fn a_live_idle_moves_as_fast_as_the_training_frames() {
        let idle = vec![Command::Idle { duration: 8.0, radius: Some(0.5), poses: vec![], hover: None }];
        with_lib(vec![], |lib| {
            let want = lib.dynamics[0].expect("the arc moves").training_speed;
            let tuned = Settings { method: Method::TUNED, ..Settings::paper() };
            let lib = Library::new(lib.models.clone(), lib.frames.clone(), vec![], &tuned);
            let speeds: Vec<f64> =
                (0..6).map(|seed| mean_speed(&run(&lib, &script(idle.clone(), seed), &tuned).unwrap(), 12)).collect();
            let mean = speeds.iter().sum::<f64>() / speeds.len() as f64;
            assert!((0.6 * want..1.4 * want).contains(&mean), "tuned idle {mean:.3} vs training {want:.3}: {speeds:?}");
            let paper = mean_speed(&run(&lib, &script(idle.clone(), 0), &Settings::paper()).unwrap(), 12);
            assert!(paper < 0.5 * want, "the paper's idle {paper:.3} vs training {want:.3}");
        });
    }

    /// A label whose training motion is far faster than an idle disc allows: `live-idle`
    /// caps the random force at the constraint's pull ($\alpha \le (\omega_0^2 r)^2$), and
    /// the idle stays in its disc instead of diverging (a regression: dragon-face's `roar`
    /// calibrated to $\alpha = 3.1\times10^5$ and left for $10^{153}$ latent units).
    #[test]
    fn a_live_idle_stays_in_a_disc_too_small_for_its_label() {
        let set = Settings { radius: 0.01, method: Method::TUNED, ..Settings::paper() };
        with_lib(vec![], |lib| {
            let lib = Library::new(lib.models.clone(), lib.frames.clone(), vec![], &set);
            let cap = (set.particle.omega0.powi(2) * set.radius).powi(2);
            let alpha = lib.dynamics[0].expect("the arc moves").random_variance;
            assert!(alpha <= cap * (1.0 + 1e-12), "alpha {alpha} above the cap {cap}");
            let idle = vec![Command::Idle { duration: 8.0, radius: None, poses: vec![], hover: None }];
            for seed in 0..4 {
                let out = run(&lib, &script(idle.clone(), seed), &set).unwrap();
                let x0 = &out[0].x;
                let worst = out.iter().map(|f| dist(&f.x, x0)).fold(0.0, f64::max);
                assert!(worst < 4.0 * set.radius, "seed {seed}: strays {worst}");
            }
        });
    }

    /// Two bridges to b: the nearer one lands at b's centre, far from every b training
    /// latent; the farther one lands on b's arc. The paper takes the nearer, `landing-choice`
    /// the one whose travel plus landing is shorter; `settle` then brings the particle to a
    /// b training latent, where without it the particle stays at the landing.
    #[test]
    fn landing_choice_and_settle_end_where_the_target_label_lives() {
        let near = link("a", "b", [1.45, 0.2], [0.0, 0.0]);
        let far = link("a", "b", [1.2, 0.9], [1.2, 0.9]);
        let cmds = vec![
            Command::Transition { to: "b".into(), blend_frames: Some(6) },
            Command::Idle { duration: 1.0, radius: None, poses: vec![], hover: None },
        ];
        let end_of = |method: Method| {
            let set = Settings { method, speed: Some(2.0), ..Settings::paper() };
            with_lib(vec![], |lib| {
                let lib = Library::new(lib.models.clone(), lib.frames.clone(), vec![near.clone(), far.clone()], &set);
                let out = run(&lib, &script(cmds.clone(), 1), &set).unwrap();
                let sw = out.iter().position(|f| f.model == 1).unwrap();
                let arc = |x: &[f64]| lib.frames[1].iter().map(|f| dist(&f.x, x)).fold(f64::INFINITY, f64::min);
                (out[sw].x.clone(), arc(&out.last().unwrap().x))
            })
        };
        let (paper_switch, paper_end) = end_of(Method::PAPER);
        assert!(dist(&paper_switch, &[0.0, 0.0]) < 0.3, "the paper lands at the nearest bridge's end {paper_switch:?}");
        assert!(paper_end > 0.8, "and idles there, {paper_end:.2} from b's latents");
        let choice = Method { bridge_choice: BridgeChoice::TravelAndLanding, ..Method::PAPER };
        let (choice_switch, _) = end_of(choice);
        assert!(dist(&choice_switch, &[1.2, 0.9]) < 0.3, "landing-choice takes the other {choice_switch:?}");
        let (_, settled) = end_of(Method { settle: true, ..Method::PAPER });
        assert!(settled < 0.25 * 1.25, "settle ends {settled:.2} from b's latents");
    }

    /// PLAY follows the segment's embedding: the controls match the model's reconstruction
    /// of each training frame closely.
    #[test]
    fn play_reproduces_its_segment() {
        let cmds = vec![Command::Play { segment: Some(1), clip: None }];
        with_lib(vec![], |lib| {
            let out = run(lib, &script(cmds, 3), &Settings { random_variance: 0.0, ..Settings::paper() }).unwrap();
            let m = lib.models[0];
            let seg: Vec<&TrainingFrame> = lib.frames[0].iter().filter(|f| f.segment == 1).collect();
            let played = &out[out.len() - (seg.len() - 1)..];
            let mut want = vec![0.0; 3];
            let mut worst: f64 = 0.0;
            for (f, t) in played.iter().zip(&seg[1..]) {
                m.controls_into(&t.x, &mut [0.0; 3], &mut want);
                worst = worst.max(dist(&f.controls, &want));
            }
            assert!(worst < 0.1, "worst control error {worst}");
        });
    }
}
