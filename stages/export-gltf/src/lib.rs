//! The export-gltf stage: for a glTF character (the rig the controls table names), every
//! script of a `curves` artifact becomes a named animation (`<prefix><script>`) in a copy of
//! the character's `.glb`, which Blender or any glTF viewer plays
//! ([`reprise_gltf::export`]).

use std::path::PathBuf;

use clap::Parser;
use reprise_artifact::controls::{Controls, RigRef};
use reprise_artifact::curves;
use reprise_gltf::ExportClip;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

/// `reprise-export-gltf`: synthesized curves into a copy of the glTF character.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-export-gltf", version, about)]
pub struct Args {
    /// Input: the synthesized curves.
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub curves: PathBuf,
    /// Input: the controls table (names the glTF character).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub controls: PathBuf,
    /// Output: the character with the new animations (.glb).
    #[arg(long, value_name = "FILE")]
    #[serde(skip)]
    pub glb: PathBuf,
    /// Prefix of the new animations' names (then the script's name).
    #[arg(long, default_value = "reprise_")]
    pub prefix: String,
    /// Only validate the flags and exit.
    #[arg(long)]
    #[serde(skip)]
    pub check: bool,
}

/// Runs the stage; returns (animation name, frames) per exported clip.
pub fn run(args: &Args) -> StageResult<Option<Vec<(String, usize)>>> {
    if args.check {
        return Ok(None);
    }
    let controls = Controls::read(&args.controls)?;
    let RigRef::Gltf { path, blake3 } = &controls.rig else {
        return Err(StageError::Input(format!(
            "{}: the rig is not a glTF character ({:?}); only glTF characters can be exported into",
            args.controls.display(),
            controls.rig
        )));
    };
    let src = PathBuf::from(path);
    if reprise_artifact::provenance::hash_file(&src)? != *blake3 {
        return Err(StageError::Input(format!("{}: changed since ingest read it; rerun ingest", src.display())));
    }
    let c = curves::read(&args.curves)?;
    let n = c.controls.len();
    let mut names: Vec<&str> = c.script.iter().map(String::as_str).collect();
    names.dedup();
    let clips: Vec<ExportClip> = names
        .iter()
        .map(|name| {
            let rows: Vec<usize> = (0..c.script.len()).filter(|&r| c.script[r] == *name).collect();
            ExportClip {
                name: format!("{}{name}", args.prefix),
                fps: c.fps,
                controls: c.controls.clone(),
                values: rows.iter().flat_map(|&r| c.values[r * n..(r + 1) * n].iter().copied()).collect(),
            }
        })
        .collect();
    reprise_gltf::export(&src, &args.glb, &clips).map_err(|e| StageError::Input(e.to_string()))?;
    Ok(Some(clips.iter().map(|c| (c.name.clone(), c.values.len() / n.max(1))).collect()))
}

/// What the stage reads and writes, for the runner's wiring by artifact
/// ([`reprise_stagekit::wiring`]); the roles are this stage's flags.
pub const WIRING: reprise_stagekit::wiring::Wiring = {
    use reprise_stagekit::wiring;
    wiring::Wiring {
        stage: "export-gltf",
        bin: "reprise-export-gltf",
        inputs: &[wiring::required("curves", "curves.parquet"), wiring::required("controls", "controls.parquet")],
        outputs: &[wiring::artifact("glb", "exported.glb")],
        derived: &[],
        partition: wiring::Partition::Whole,
    }
};

#[cfg(test)]
mod tests {
    use super::*;

    fn args(dir: &std::path::Path, rig: RigRef) -> Args {
        let controls = dir.join("controls.parquet");
        let prov = reprise_stagekit::provenance("test", "0", &());
        Controls { controls: vec![], rig }.write(&controls, &prov).unwrap();
        Args {
            curves: dir.join("curves.parquet"),
            controls,
            glb: dir.join("out.glb"),
            prefix: "r_".into(),
            check: false,
        }
    }

    /// Catalogue: controls of a character that is not glTF (a CSV or BVH source) cannot
    /// be exported into; the error names the controls file, and nothing is written.
    #[test]
    fn a_rig_that_is_not_gltf_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = args(dir.path(), RigRef::None);
        let e = run(&a).unwrap_err();
        assert_eq!(e.code(), reprise_stagekit::exit::INPUT);
        assert!(e.to_string().contains("controls.parquet: the rig is not a glTF character"), "{e}");
        assert!(!a.glb.exists());
    }

    /// Catalogue: a character file edited since ingest read it is refused (its animations
    /// and the curves' controls might no longer match).
    #[test]
    fn a_character_changed_since_ingest_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let glb = dir.path().join("char.glb");
        std::fs::write(&glb, b"glTF then edited").unwrap();
        let rig = RigRef::Gltf { path: glb.display().to_string(), blake3: "0".repeat(64) };
        let e = run(&args(dir.path(), rig)).unwrap_err().to_string();
        assert!(e.contains("char.glb: changed since ingest read it; rerun ingest"), "{e}");
    }
}
