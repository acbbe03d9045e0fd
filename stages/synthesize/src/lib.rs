//! The synthesize stage (Bailey et al. 2016 §5): every script of a scripts file (see
//! [`reprise_synth_engine::script`]) is run by the command engine ([`reprise_synth_engine::engine`])
//! over the label models and bridges, and written as rig-control curves. Scripts run in
//! parallel; each is deterministic for its seed.

use std::time::Instant;

use clap::{Parser, ValueEnum};
use rayon::prelude::*;
use reprise_artifact::curves::{self, Curves};
pub use reprise_model_library::LibraryParts;
use reprise_stagekit::{StageError, StageResult};
use reprise_synth_engine::engine::{self, Settings};
use reprise_synth_engine::method::{BridgeChoice, IdleRule, Method};
use reprise_synth_engine::particle::ConstraintSign;
use reprise_synth_engine::path::EdgeCost;
use reprise_synth_engine::script::Script;
use serde::Serialize;

/// The constraint multiplier's sign.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Sign {
    /// method.md §6: the Baumgarte law solved correctly.
    Corrected,
    /// The paper's Eq. 9–10 as printed (for comparison; the constraint never pulls).
    SeedLiteral,
}

/// How the MOVE graph's edges cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Cost {
    /// ‖Δ‖^p.
    Power,
    /// ‖Δ‖^−p (the paper's weight read as a cost).
    InversePower,
}

/// How the random force and drag are set (`docs/method.md`, improvement `live-idle`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Idle {
    /// --random-variance and --drag for every label (the paper's fixed force).
    Fixed,
    /// Each label's own, from its training frames.
    FromData,
}

/// Which bridge TRANSITION takes (improvement `landing-choice`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BridgeRule {
    /// The nearest (the paper).
    Nearest,
    /// Least travel-plus-landing time.
    TravelAndLanding,
}

reprise_stagekit::stage_io! {
    stage: "synthesize", bin: "reprise-synthesize",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the GPLVM models.
        gplvm_models: required "gplvm_models.parquet",
        /// Input: the GPLVM latents (which training frame each latent point is).
        latents: required "gplvm_latents.parquet",
        /// Input: the PCA models.
        pca_models: required "pca_models.parquet",
        /// Input: the scales.
        scales: required "scales.parquet",
        /// Input: the bridges.
        bridges: required "bridges.parquet",
        /// Input: a scripts file (TOML: one script, or several as `[[script]]` tables).
        scripts: source "a scripts file (TOML)",
    }
    outputs {
        /// Output: the curves.
        curves: artifact "curves.parquet",
    }
}

/// `reprise-synthesize`: scripts to rig-control curves.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-synthesize", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Frames per second.
    #[arg(long, default_value_t = 24.0)]
    pub fps: f64,
    /// Default path radius (latent units).
    #[arg(long, default_value_t = 0.25)]
    pub radius: f64,
    /// Baumgarte ω₀ (s⁻¹).
    #[arg(long, default_value_t = 8.0)]
    pub omega0: f64,
    /// The multiplier formula.
    #[arg(long, value_enum, default_value_t = Sign::Corrected)]
    pub sign: Sign,
    /// RK4 steps per frame, at least (more when ω₀/fps > 1/2).
    #[arg(long, default_value_t = 2)]
    pub substeps: usize,
    /// a of Eq. 11 (force toward probable regions).
    #[arg(long, default_value_t = 2.0)]
    pub density_force: f64,
    /// v of Eq. 11 (relative latent density).
    #[arg(long, default_value_t = 0.2)]
    pub density_threshold: f64,
    /// Random force variance α.
    #[arg(long, default_value_t = 0.25)]
    pub random_variance: f64,
    /// Random force squared time scale γ (s²).
    #[arg(long, default_value_t = 0.05)]
    pub random_gamma: f64,
    /// Linear drag c (s⁻¹; 0 = the paper, which names none).
    #[arg(long, default_value_t = 2.0)]
    pub drag: f64,
    /// TRANSITION blend length in frames.
    #[arg(long, default_value_t = 12)]
    pub blend_frames: usize,
    /// Latent speed limit of every approach (latent units per second); default: each
    /// model's median training speed times --speed-factor.
    #[arg(long)]
    pub speed: Option<f64>,
    /// Multiplier of the models' median training speed (without --speed).
    #[arg(long, default_value_t = 1.0)]
    pub speed_factor: f64,
    /// Seconds an approach (to a target, a bridge, a segment) may take before it fails.
    #[arg(long, default_value_t = 10.0)]
    pub timeout: f64,
    /// MOVE graph edge cost.
    #[arg(long, value_enum, default_value_t = Cost::Power)]
    pub graph_cost: Cost,
    /// MOVE graph cost exponent p.
    #[arg(long, default_value_t = 4.0)]
    pub graph_power: f64,
    /// MOVE graph neighbours per latent point (0: the paper's complete graph).
    #[arg(long, default_value_t = 0)]
    pub graph_k: usize,
    /// Idle force and drag.
    #[arg(long, value_enum, default_value_t = Idle::FromData)]
    pub idle: Idle,
    /// TRANSITION's bridge.
    #[arg(long, value_enum, default_value_t = BridgeRule::TravelAndLanding)]
    pub bridge_choice: BridgeRule,
    /// After TRANSITION, move to the target label's training pose nearest the landing
    /// (improvement `settle`; `--settle false` idles at the landing, as the paper does).
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    pub settle: bool,
}

impl Args {
    /// The engine settings.
    pub fn settings(&self) -> Settings {
        let d = Settings::default();
        Settings {
            fps: self.fps,
            particle: reprise_synth_engine::particle::ParticleParams {
                omega0: self.omega0,
                sign: match self.sign {
                    Sign::Corrected => ConstraintSign::Corrected,
                    Sign::SeedLiteral => ConstraintSign::SeedLiteral,
                },
                substeps: self.substeps,
                ..d.particle
            },
            radius: self.radius,
            density_force: self.density_force,
            density_threshold: self.density_threshold,
            random_variance: self.random_variance,
            random_gamma: self.random_gamma,
            drag: self.drag,
            blend_frames: self.blend_frames,
            speed: self.speed,
            speed_factor: self.speed_factor,
            timeout_seconds: self.timeout,
            graph_cost: match self.graph_cost {
                Cost::Power => EdgeCost::Power(self.graph_power),
                Cost::InversePower => EdgeCost::InversePower(self.graph_power),
            },
            graph_k: self.graph_k,
            method: Method {
                idle: match self.idle {
                    Idle::Fixed => IdleRule::Fixed,
                    Idle::FromData => IdleRule::FromData,
                },
                bridge_choice: match self.bridge_choice {
                    BridgeRule::Nearest => BridgeChoice::Nearest,
                    BridgeRule::TravelAndLanding => BridgeChoice::TravelAndLanding,
                },
                settle: self.settle,
            },
            ..d
        }
    }

    fn validate(&self) -> StageResult<()> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let ok = pos(self.fps)
            && pos(self.radius)
            && pos(self.omega0)
            && self.substeps >= 1
            && self.density_force >= 0.0
            && self.random_variance >= 0.0
            && pos(self.random_gamma)
            && self.drag >= 0.0
            && self.blend_frames >= 1
            && self.speed.is_none_or(pos)
            && pos(self.speed_factor)
            && pos(self.timeout)
            && pos(self.graph_power);
        if ok {
            Ok(())
        } else {
            Err(StageError::Config(
                "need positive --fps, --radius, --omega0, --random-gamma, --graph-power, --speed, \
                 --speed-factor, --timeout; --substeps and --blend-frames >= 1; non-negative forces and drag"
                    .into(),
            ))
        }
    }
}

/// One script's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptSummary {
    /// Name.
    pub name: String,
    /// Frames.
    pub frames: usize,
    /// Model switches.
    pub switches: usize,
    /// Microseconds per frame (particle step + reconstruction).
    pub us_per_frame: f64,
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Vec<ScriptSummary>>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let text = reprise_artifact::input::read_text(&args.io.scripts, reprise_artifact::input::MAX_TEXT_BYTES)
        .map_err(|e| StageError::Input(e.to_string()))?;
    let stem = args.io.scripts.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let scripts = Script::parse_file(&text, &stem)
        .map_err(|e| StageError::Input(format!("{}: {e}", args.io.scripts.display())))?;
    let parts = LibraryParts::load(
        &args.io.gplvm_models,
        &args.io.latents,
        &args.io.pca_models,
        &args.io.scales,
        &args.io.bridges,
    )?;
    let models = &parts.models;
    let settings = args.settings();
    let lib = parts.library(&settings);
    let results: Vec<StageResult<(String, Vec<engine::Frame>, f64)>> = scripts
        .par_iter()
        .map(|s| {
            let name = s.name.clone().unwrap_or_default();
            let start = Instant::now();
            let out = engine::run(&lib, s, &settings)
                .map_err(|e| StageError::Input(format!("{}: script `{name}`: {e}", args.io.scripts.display())))?;
            Ok((name, out, start.elapsed().as_secs_f64()))
        })
        .collect();
    let mut curves = Curves { fps: args.fps, controls: models.controls.clone(), ..Default::default() };
    let mut summaries = Vec::new();
    for r in results {
        let (name, out, secs) = r?;
        let switches = out.windows(2).filter(|w| w[0].model != w[1].model).count();
        summaries.push(ScriptSummary {
            name: name.clone(),
            frames: out.len(),
            switches,
            us_per_frame: secs * 1e6 / out.len().max(1) as f64,
        });
        for f in out {
            curves.script.push(name.clone());
            curves.frame.push(f.frame as i64);
            curves.time.push(f.time);
            curves.model.push(lib.models[f.model].label.clone());
            curves.command.push(f.command as i64);
            curves.x.push(f.x);
            curves.values.extend(f.controls);
        }
    }
    curves::write(&args.io.curves, &curves, &provenance)?;
    Ok(Some(summaries))
}
