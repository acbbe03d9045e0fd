//! `controls`: one row per rig control, in the column order of the frame table.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `name` | Utf8 | control name (the frame table's column) |
//! | `group` | Utf8 | rig group, e.g. `jaw`, `eyes`, `shapes_fine` (`default` if unknown) |
//! | `unit` | Utf8 | `deg`, `slider`, `cm`, `rad`, … or `unknown` |
//! | `default` | Float64 | rest value |
//! | `min` | Float64 | lower bound (the rig's, or the observed minimum) |
//! | `max` | Float64 | upper bound (the rig's, or the observed maximum) |
//! | `animated` | Boolean | whether the control moves anywhere in the corpus |
//!
//! Metadata: `reprise.rig`, a JSON [`RigRef`] naming the rig that evaluates these
//! controls, so every later stage evaluates the same rig without being told again.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the controls table.
pub const CONTROLS: Kind = Kind { name: "controls", version: 1 };
/// Metadata key: the rig reference (JSON).
pub const KEY_RIG: &str = "reprise.rig";

/// Which rig evaluates a control vector into a mesh.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum RigRef {
    /// The built-in dragon-face rig, rebuilt deterministically from its seed.
    DragonFace {
        /// Generator seed.
        seed: u64,
        /// Rig math version; a mismatch means the artifacts are stale.
        version: String,
    },
    /// A glTF 2.0 file: linear blend skinning and morph targets of its default scene.
    Gltf {
        /// The file, as given to ingest (relative to the pipeline directory).
        path: String,
        /// blake3 of the file when it was ingested.
        blake3: String,
    },
    /// A BVH skeleton: forward kinematics, joint positions as vertices.
    Bvh {
        /// The file, as given to ingest.
        path: String,
        /// blake3 of the file when it was ingested.
        blake3: String,
    },
    /// A blendshape face: a zip of OBJ meshes, a neutral and one per shape
    /// (`reprise_blendshape`).
    Blendshapes {
        /// The zip, as given to ingest.
        path: String,
        /// blake3 of the file when it was ingested.
        blake3: String,
    },
    /// A user's evaluator process speaking Arrow IPC over stdin/stdout.
    External {
        /// Program and arguments.
        command: Vec<String>,
    },
    /// No rig is known (curve tables without a rig): mesh-space steps are unavailable.
    None,
}

/// One rig control.
#[derive(Debug, Clone, PartialEq)]
pub struct Control {
    /// Name.
    pub name: String,
    /// Group.
    pub group: String,
    /// Unit.
    pub unit: String,
    /// Rest value.
    pub default: f64,
    /// Lower bound.
    pub min: f64,
    /// Upper bound.
    pub max: f64,
    /// Whether it moves in the corpus.
    pub animated: bool,
}

/// The controls table and its rig.
#[derive(Debug, Clone, PartialEq)]
pub struct Controls {
    /// Controls in frame-table column order.
    pub controls: Vec<Control>,
    /// The rig that evaluates them.
    pub rig: RigRef,
}

impl Controls {
    /// Writes the controls table atomically.
    pub fn write(&self, path: &Path, provenance: &Provenance) -> Result<()> {
        let c = &self.controls;
        let cols = Columns::new()
            .str("name", &c.iter().map(|c| c.name.as_str()).collect::<Vec<_>>())
            .str("group", &c.iter().map(|c| c.group.as_str()).collect::<Vec<_>>())
            .str("unit", &c.iter().map(|c| c.unit.as_str()).collect::<Vec<_>>())
            .f64("default", c.iter().map(|c| c.default).collect())
            .f64("min", c.iter().map(|c| c.min).collect())
            .f64("max", c.iter().map(|c| c.max).collect())
            .bool("animated", c.iter().map(|c| c.animated).collect());
        let rig = serde_json::to_string(&self.rig).expect("rig refs serialise");
        crate::table::write(path, CONTROLS, cols, provenance, &[(KEY_RIG.into(), rig)])
    }

    /// Reads a controls table.
    pub fn read(path: &Path) -> Result<Self> {
        let t = Table::read(path, CONTROLS)?;
        let rig =
            serde_json::from_str(t.meta(KEY_RIG)?).map_err(|e| t.invalid(format!("metadata `{KEY_RIG}`: {e}")))?;
        let (name, group, unit) = (t.str("name")?, t.str("group")?, t.str("unit")?);
        let (default, min, max, animated) = (t.f64("default")?, t.f64("min")?, t.f64("max")?, t.bool("animated")?);
        let controls = (0..t.rows())
            .map(|i| Control {
                name: name[i].into(),
                group: group[i].into(),
                unit: unit[i].into(),
                default: default[i],
                min: min[i],
                max: max[i],
                animated: animated[i],
            })
            .collect();
        Ok(Self { controls, rig })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every rig reference survives the metadata round trip.
    #[test]
    fn controls_and_rig_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.parquet");
        let control = Control {
            name: "Hips.rx".into(),
            group: "joints".into(),
            unit: "rad".into(),
            default: 0.0,
            min: -1.0,
            max: 1.0,
            animated: true,
        };
        for rig in [
            RigRef::DragonFace { seed: 7, version: "v".into() },
            RigRef::Gltf { path: "a.glb".into(), blake3: "00".into() },
            RigRef::Bvh { path: "a.bvh".into(), blake3: "11".into() },
            RigRef::Blendshapes { path: "face.zip".into(), blake3: "22".into() },
            RigRef::External { command: vec!["rig".into(), "--fast".into()] },
            RigRef::None,
        ] {
            let table = Controls { controls: vec![control.clone()], rig };
            table.write(&path, &Provenance::new("ingest", "0", serde_json::json!({}))).unwrap();
            assert_eq!(Controls::read(&path).unwrap(), table);
        }
    }
}
