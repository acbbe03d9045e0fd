//! The positions stage: each frame of the chosen clips through the rig, keeping the
//! positions of chosen points (mesh vertices; a skeleton's joints). It stands in for motion
//! that exists only as positions (capture, a mesh cache, another tool's skeleton) when the
//! curves are known, so inverse rig mapping can be measured against them.
//!
//! The points are those of a fitted mapping when one is given (`--invrig`), else
//! `--points` spread over the rest mesh ([`reprise_invrig::points::spread`]), the same rule
//! `invrig-fit` uses.

use clap::Parser;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::Frames;
use reprise_artifact::invrig::Invrig;
use reprise_artifact::positions::Positions;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "positions", bin: "reprise-positions",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the frame table (rig-control curves).
        frames: required "frames.parquet",
        /// Input: the controls table (names the rig).
        controls: required "controls.parquet",
        /// Input (optional): a fitted mapping whose points to keep.
        invrig: optional "invrig.parquet",
    }
    outputs {
        /// Output: the positions table.
        positions: artifact "positions.parquet",
    }
}

/// `reprise-positions`: curves to point positions through the rig.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-positions", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Points to keep, spread over the rest mesh (0: every vertex). Ignored with --invrig.
    #[arg(long, default_value_t = 0)]
    pub points: usize,
    /// Clips to keep: glob patterns of clip names (comma-separated; none: every clip).
    #[arg(long, value_delimiter = ',')]
    pub clips: Vec<String>,
}

/// What the stage wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames written.
    pub frames: usize,
    /// Points per frame.
    pub points: usize,
    /// Clips written.
    pub clips: usize,
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    let matcher = reprise_stagekit::clips::matcher(&args.clips, "--clips")?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let frames = Frames::read(&args.io.frames)?;
    let controls = Controls::read(&args.io.controls)?;
    let rig = reprise_stagekit::rig::open_rig(&controls, &frames.controls)?;
    let vertices = rig.0.vertex_count();
    let points: Vec<usize> = match &args.io.invrig {
        Some(path) => {
            let mapping = Invrig::read(path)?.mapping;
            reprise_invrig::points::check(&mapping.points, vertices)
                .map_err(|e| StageError::Input(format!("{}: {e}", path.display())))?
        }
        None => reprise_invrig::points::spread(
            &rig.0.evaluate(&rig.0.rest_pose()).map_err(|e| StageError::Input(e.to_string()))?,
            args.points,
        ),
    };
    let rows: Vec<usize> =
        (0..frames.rows()).filter(|&r| matcher.as_ref().is_none_or(|m| m.is_match(&frames.clip[r]))).collect();
    if rows.is_empty() {
        return Err(StageError::Input(format!(
            "{}: no clip matches --clips {:?}",
            args.io.frames.display(),
            args.clips
        )));
    }
    let meshes =
        reprise_stagekit::rig::meshes(&rig, &rows.iter().map(|&r| frames.row(r).to_vec()).collect::<Vec<_>>())?;
    let out = Positions {
        fps: frames.fps,
        points: points.iter().map(|&p| p as i64).collect(),
        clip: rows.iter().map(|&r| frames.clip[r].clone()).collect(),
        frame: rows.iter().map(|&r| frames.frame[r]).collect(),
        values: reprise_invrig::points::select(&meshes, vertices, &points),
    };
    out.write(&args.io.positions, &provenance)?;
    let clips = out.clip_runs().len();
    Ok(Some(Summary { frames: out.frames(), points: points.len(), clips }))
}
