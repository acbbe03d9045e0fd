//! Face capture as curves on a blendshape face: the Live Link Face take (ARKit weights,
//! 60 fps) ingested onto the ARKit reference shapes, evaluated through them.

use reprise_artifact::controls::{Controls, RigRef};
use reprise_artifact::frames::Frames;
use reprise_artifact::positions::Positions;
use reprise_stagekit::exit;

use crate::util::{shared_dataset, Project};

/// Live Link Face's columns that are no ARKit reference shape: its count column, the
/// tongue (the reference set has no `tongueOut`) and the head and eye rotations.
const NOT_SHAPES: &str = r#"["BlendShapeCount", "TongueOut", "HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll", "RightEyeYaw", "RightEyePitch", "RightEyeRoll"]"#;

fn pipeline(csv: &std::path::Path, zip: &std::path::Path, ignore: &str) -> String {
    format!(
        r#"[pipeline]
name = "face"
[stage.ingest]
inputs.curves = "{}"
inputs.blendshapes = "{}"
[stage.ingest.params]
fps = 60.0
source_fps = 60.0
time_column = "Timecode"
ignore_columns = {ignore}
[stage.positions]
"#,
        csv.display(),
        zip.display()
    )
}

#[test]
fn the_live_link_face_take_plays_on_the_arkit_shapes() {
    let Some(csv) = shared_dataset(
        "the_live_link_face_take_plays_on_the_arkit_shapes",
        "livelinkface_csv/MySlate_3_Jason_Millers_iPhone.csv",
    ) else {
        return;
    };
    let Some(zip) = shared_dataset(
        "the_live_link_face_take_plays_on_the_arkit_shapes",
        "arkit_blendshapes/ARKit_reference_blendshapes.zip",
    ) else {
        return;
    };
    let p = Project::empty();
    // Columns that name no shape are refused, listed, with the way to leave them out.
    p.write("pipeline.toml", &pipeline(&csv, &zip, r#"["BlendShapeCount"]"#));
    let err = p.reprise(&["run"]).fails(exit::INPUT);
    assert!(err.contains("TongueOut") && err.contains("HeadYaw") && err.contains("--ignore-columns"), "{err}");

    p.write("pipeline.toml", &pipeline(&csv, &zip, NOT_SHAPES));
    p.reprise(&["run"]).ok();
    let frames = Frames::read(&p.path("artifacts/face/frames.parquet")).unwrap();
    assert_eq!(frames.controls.len(), 51);
    assert!(frames.controls.iter().any(|c| c == "jawOpen"), "the shapes' own names");
    assert!((320..=330).contains(&frames.rows()), "about 328 frames at 60 fps: {}", frames.rows());
    let controls = Controls::read(&p.path("artifacts/face/controls.parquet")).unwrap();
    assert!(matches!(controls.rig, RigRef::Blendshapes { .. }), "{:?}", controls.rig);
    // The take moves the face: every frame's mesh through the shapes, the jaw opening.
    let positions = Positions::read(&p.path("artifacts/face/positions.parquet"), None).unwrap();
    assert_eq!(positions.points.len(), 1220);
    let jaw = frames.controls.iter().position(|c| c == "jawOpen").unwrap();
    let open = (0..frames.rows()).max_by(|&a, &b| frames.row(a)[jaw].total_cmp(&frames.row(b)[jaw])).unwrap();
    let closed = (0..frames.rows()).min_by(|&a, &b| frames.row(a)[jaw].total_cmp(&frames.row(b)[jaw])).unwrap();
    let moved = positions.row(open).iter().zip(positions.row(closed)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(frames.row(open)[jaw] > 0.1 && moved > 0.0, "jaw {} moved {moved}", frames.row(open)[jaw]);
}
