//! The positions stage: each frame of the chosen clips through the rig, keeping the
//! positions of chosen points (mesh vertices; a skeleton's joints). It stands in for motion
//! that exists only as positions (capture, a mesh cache, another tool's skeleton) when the
//! curves are known, so inverse rig mapping can be measured against them.
//!
//! The points are those of a fitted mapping when one is given (`--invrig`), else those a
//! landmarks file lists (`--landmarks`: vertex indices, one per line, `#` comments), else
//! `--points` spread over the rest mesh ([`reprise_invrig::points::spread`]), the same rule
//! `invrig-fit` uses. `--noise` adds Gaussian noise of that standard deviation to every
//! coordinate (a capture system's), drawn from `--seed`.

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
        /// Input (optional): the points to keep, one vertex index per line.
        landmarks: optional "landmarks.txt",
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
    /// Standard deviation of Gaussian noise added to every coordinate, the rig's length unit.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Reads a landmarks file: one non-negative vertex index per line; blank lines and text
/// after `#` are ignored.
///
/// # Errors
/// An unreadable file, or a line that is not an index (named by number), or no index.
pub fn read_landmarks(path: &std::path::Path) -> StageResult<Vec<usize>> {
    let text = std::fs::read_to_string(path).map_err(|e| StageError::Input(format!("{}: {e}", path.display())))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let body = line.split('#').next().unwrap_or("").trim();
        if body.is_empty() {
            continue;
        }
        out.push(body.parse::<usize>().map_err(|_| {
            StageError::Input(format!("{}: line {}: `{body}` is not a vertex index", path.display(), i + 1))
        })?);
    }
    if out.is_empty() {
        return Err(StageError::Input(format!("{}: lists no vertex", path.display())));
    }
    Ok(out)
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
    if !(args.noise.is_finite() && args.noise >= 0.0) {
        return Err(StageError::Config(format!("--noise {} must be finite and at least 0", args.noise)));
    }
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
        None if args.io.landmarks.is_some() => {
            let path = args.io.landmarks.as_deref().expect("checked");
            let listed = read_landmarks(path)?.into_iter().map(|p| p as i64).collect::<Vec<_>>();
            reprise_invrig::points::check(&listed, vertices)
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
        values: noisy(reprise_invrig::points::select(&meshes, vertices, &points), args.noise, args.seed),
    };
    out.write(&args.io.positions, &provenance)?;
    let clips = out.clip_runs().len();
    Ok(Some(Summary { frames: out.frames(), points: points.len(), clips }))
}

/// `values` plus independent Gaussian noise of standard deviation `sigma` (none at 0).
fn noisy(mut values: Vec<f64>, sigma: f64, seed: u64) -> Vec<f64> {
    if sigma > 0.0 {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // Box–Muller: u1 in (0, 1] keeps the logarithm finite.
        for v in values.iter_mut() {
            let (u1, u2): (f64, f64) = (1.0 - rng.gen::<f64>(), rng.gen());
            *v += sigma * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        }
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_has_the_asked_deviation_and_none_changes_nothing() {
        let v = vec![1.0; 20_000];
        assert_eq!(noisy(v.clone(), 0.0, 1), v);
        let n = noisy(v, 0.5, 3);
        let sd = (n.iter().map(|x| (x - 1.0) * (x - 1.0)).sum::<f64>() / n.len() as f64).sqrt();
        assert!((sd - 0.5).abs() < 0.01, "{sd}");
    }

    #[test]
    fn a_landmarks_file_is_read_and_a_bad_line_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("l.txt");
        std::fs::write(&path, "# markers\n12\n\n7  # chin\n").unwrap();
        assert_eq!(read_landmarks(&path).unwrap(), vec![12, 7]);
        std::fs::write(&path, "12\nseven\n").unwrap();
        let err = read_landmarks(&path).unwrap_err().to_string();
        assert!(err.contains("line 2") && err.contains("seven"), "{err}");
        std::fs::write(&path, "# nothing\n").unwrap();
        assert!(read_landmarks(&path).unwrap_err().to_string().contains("no vertex"));
    }
}
