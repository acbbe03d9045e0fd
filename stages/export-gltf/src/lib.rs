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

reprise_stagekit::stage_io! {
    stage: "export-gltf", bin: "reprise-export-gltf",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the synthesized curves.
        curves: required "curves.parquet",
        /// Input: the controls table (names the glTF character).
        controls: required "controls.parquet",
    }
    outputs {
        /// Output: the character with the new animations (.glb).
        glb: artifact "exported.glb",
    }
}

/// `reprise-export-gltf`: synthesized curves into a copy of the glTF character.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-export-gltf", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Prefix of the new animations' names (then the script's name).
    #[arg(long, default_value = "reprise_")]
    pub prefix: String,
}

/// Runs the stage; returns (animation name, frames) per exported clip.
pub fn run(args: &Args) -> StageResult<Option<Vec<(String, usize)>>> {
    if args.io.check {
        return Ok(None);
    }
    let controls = Controls::read(&args.io.controls)?;
    let RigRef::Gltf { path, blake3 } = &controls.rig else {
        return Err(StageError::Input(format!(
            "{}: the rig is not a glTF character ({:?}); only glTF characters can be exported into",
            args.io.controls.display(),
            controls.rig
        )));
    };
    let src = PathBuf::from(path);
    if reprise_artifact::provenance::hash_file(&src)? != *blake3 {
        return Err(StageError::Input(format!("{}: changed since ingest read it; rerun ingest", src.display())));
    }
    let c = curves::read(&args.io.curves)?;
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
    let marker = reprise_artifact::provenance::output_marker(
        WIRING.stage,
        reprise_artifact::provenance::pipeline_from_env().as_deref(),
    );
    reprise_gltf::export(&src, &args.io.glb, &clips, &marker).map_err(|e| StageError::Input(e.to_string()))?;
    Ok(Some(clips.iter().map(|c| (c.name.clone(), c.values.len() / n.max(1))).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(dir: &std::path::Path, rig: RigRef) -> Args {
        let controls = dir.join("controls.parquet");
        let prov = reprise_stagekit::provenance("test", "0", &());
        Controls { controls: vec![], rig }.write(&controls, &prov).unwrap();
        Args {
            io: crate::Io { curves: dir.join("curves.parquet"), controls, glb: dir.join("out.glb"), check: false },
            prefix: "r_".into(),
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
        assert!(!a.io.glb.exists());
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
