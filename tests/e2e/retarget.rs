//! Face capture retargeted onto a rig (Bouaziz and Pauly): protocol A on the Live Link Face
//! take's noisy landmarks, protocol B onto the dragon face through the stated oracle (with
//! ten markers dropped, and poses completed from a few controls), and the bad inputs.

use reprise_artifact::curves;
use reprise_artifact::frames::Frames;
use reprise_artifact::positions::Positions;
use reprise_artifact::retarget::{read_comparison, read_frames};
use reprise_artifact::scales::{self, Scale};
use reprise_artifact::{Columns, Provenance};
use reprise_stagekit::exit;

use crate::util::{repo, shared_dataset, Project};

/// The capture (the live-link-face pipeline, with a small protocol A) and the dragon
/// pipeline (protocol B), as the repository's pipelines are, pointed at `../shared`.
fn pipelines(p: &Project, csv: &std::path::Path, zip: &std::path::Path, landmarks: &std::path::Path) {
    let face = std::fs::read_to_string(repo().join("datasets/live-link-face/pipeline.toml")).unwrap();
    let face = face
        .replace(
            "../../../shared/datasets/livelinkface_csv/MySlate_3_Jason_Millers_iPhone.csv",
            &csv.display().to_string(),
        )
        .replace(
            "../../../shared/datasets/arkit_blendshapes/ARKit_reference_blendshapes.zip",
            &zip.display().to_string(),
        )
        .replace("../../../shared/datasets/arkit_blendshapes/ARKit_landmarks.txt", &landmarks.display().to_string())
        .replace("capture_noise = 0.001", "capture_noise = 0.001\nlabels = [5, 10]\ndraws = 2\nunlabelled = 40");
    p.write("datasets/live-link-face/pipeline.toml", &face);
    let dragon = std::fs::read_to_string(repo().join("datasets/live-link-face-dragon/pipeline.toml")).unwrap();
    p.write("datasets/live-link-face-dragon/pipeline.toml", &dragon);
    p.write(
        "datasets/live-link-face-dragon/oracle.toml",
        &std::fs::read_to_string(repo().join("datasets/live-link-face-dragon/oracle.toml")).unwrap(),
    );
    p.write(
        "datasets/dragon-face/labels.toml",
        &std::fs::read_to_string(repo().join("datasets/dragon-face/labels.toml")).unwrap(),
    );
}

/// Mean over frames of the RMS vertex distance between the dragon's meshes of `a` and `b`
/// (frames × controls, the rig's control order).
fn mesh_distance(a: &[f64], b: &[f64], controls: usize) -> f64 {
    let rig = reprise_dragon_face::DragonRig::new(7);
    let mut ma = vec![0.0; 3 * rig.vertex_count()];
    let mut mb = ma.clone();
    let frames = a.len() / controls;
    let mut sum = 0.0;
    for (pa, pb) in a.chunks_exact(controls).zip(b.chunks_exact(controls)) {
        rig.evaluate(pa, &mut ma);
        rig.evaluate(pb, &mut mb);
        sum += reprise_stagekit::rig::mesh_rmse(&ma, &mb);
    }
    sum / frames as f64
}

#[test]
fn a_face_capture_is_retargeted_onto_the_dragon_and_plays() {
    let test = "a_face_capture_is_retargeted_onto_the_dragon_and_plays";
    let Some(csv) = shared_dataset(test, "livelinkface_csv/MySlate_3_Jason_Millers_iPhone.csv") else { return };
    let Some(zip) = shared_dataset(test, "arkit_blendshapes/ARKit_reference_blendshapes.zip") else { return };
    let Some(landmarks) = shared_dataset(test, "arkit_blendshapes/ARKit_landmarks.txt") else { return };
    let p = Project::empty();
    pipelines(&p, &csv, &zip, &landmarks);
    p.reprise(&["run", "-p", "datasets/live-link-face/pipeline.toml"]).ok();

    // Protocol A: every method at each label count, a chart, and the bar stated.
    let table = read_comparison(&p.path("artifacts/live-link-face/retarget_comparison.parquet")).unwrap();
    assert_eq!(table.len(), 2 * reprise_retarget::protocol::Method::ALL.len());
    assert!(table.iter().all(|r| r.rms.is_finite() && r.rms > 0.0 && r.rms < 0.3 && r.draws == 2), "{table:?}");
    let report = p.read("reports/live-link-face/retarget-compare.md");
    assert!(
        report.contains("retarget-compare.svg") && report.contains("× GPR") && report.contains("the bar is"),
        "{report}"
    );
    assert!(p.read("reports/live-link-face/retarget-compare.svg").contains("<polyline"));
    let capture = Positions::read(&p.path("artifacts/live-link-face/positions.parquet"), None).unwrap();
    assert_eq!(capture.points.len(), 68, "the ARKit landmarks");

    // Protocol B: the dragon performs the take, scored against the oracle.
    p.reprise(&["run", "-p", "datasets/live-link-face-dragon/pipeline.toml"]).ok();
    let out = curves::read(&p.path("artifacts/live-link-face-dragon/curves.parquet")).unwrap();
    let truth = Frames::read(&p.path("artifacts/live-link-face-dragon/truth.parquet")).unwrap();
    assert_eq!(out.controls, truth.controls, "every dragon control");
    assert_eq!(out.script.len(), capture.frames(), "one frame per capture frame, no pose asked");
    let rows = read_frames(&p.path("artifacts/live-link-face-dragon/retarget_frames.parquet")).unwrap();
    let model = rows.iter().filter_map(|r| r.mesh_error).sum::<f64>() / rows.len() as f64;
    // Doing nothing (the rest pose) against the take's known poses.
    let c = truth.controls.len();
    let controls =
        reprise_artifact::controls::Controls::read(&p.path("artifacts/live-link-face-dragon/controls.parquet"))
            .unwrap();
    let rest: Vec<f64> = controls.controls.iter().map(|k| k.default).collect::<Vec<_>>().repeat(truth.rows());
    let still = mesh_distance(&rest, &truth.values, c);
    assert!(model < 0.5 * still, "the dragon follows the take: {model} vs {still} standing still");
    let report = p.read("reports/live-link-face-dragon/retarget.md");
    assert!(
        report.contains("| ridge |") && report.contains("| GPR |") && report.contains("projected onto"),
        "{report}"
    );
    let per_frame: Vec<f64> = rows.iter().map(|r| r.ms).collect();
    assert!(per_frame.iter().all(|ms| ms.is_finite() && *ms > 0.0));

    // The take plays in the exported glTF (one animation, both tracks) and in the player.
    let glb = reprise_gltf::ingest(&p.path("artifacts/live-link-face-dragon/retarget.glb"), capture.fps).unwrap();
    let clip = glb.clip("retargeted").expect("the animation");
    assert!((clip.frames as i64 - capture.frames() as i64).abs() <= 1, "{} frames", clip.frames);
    assert!(
        glb.controls.iter().any(|c| c.name.starts_with("retargeted"))
            && glb.controls.iter().any(|c| c.name.starts_with("known"))
    );
    let page = p.read("reports/live-link-face-dragon/retarget.html");
    assert!(page.contains("\"names\":[\"retargeted\"") && page.contains("mesh error"));

    // Ten markers dropped on every frame, and two poses completed from fixed controls.
    let dropped: Vec<String> = capture.points[..10].iter().map(i64::to_string).collect();
    let apply = |extra: &[&str]| {
        let a = "artifacts/live-link-face-dragon";
        let (model, controls) = (format!("{a}/retarget.parquet"), format!("{a}/controls.parquet"));
        let mut args = vec!["--model", &model, "--capture", "artifacts/live-link-face/positions.parquet"];
        args.extend(["--controls", &controls, "--curves", "out/curves.parquet", "--frames", "out/frames.parquet"]);
        args.extend(["--glb", "out/r.glb", "--report", "out/r.md", "--player", "out/r.html"]);
        args.extend(extra);
        p.stage("reprise-retarget-apply", &args)
    };
    let missing = dropped.join(",");
    let truth = "artifacts/live-link-face-dragon/truth.parquet";
    apply(&[
        "--truth",
        truth,
        "--missing",
        &missing,
        "--pose",
        "jaw_open=30,smile_L=0.6",
        "--pose",
        "jaw_open=4,lip_pucker=0.7,brow_down_L=0.5",
    ])
    .ok();
    let rows = read_frames(&p.path("out/frames.parquet")).unwrap();
    assert!(rows.iter().all(|r| r.missing == 30), "ten markers, thirty values");
    let blind = rows.iter().filter_map(|r| r.mesh_error).sum::<f64>() / rows.len() as f64;
    assert!(blind < 1.5 * model && blind < 0.5 * still, "ten markers fewer: {blind} vs {model}");
    let out = curves::read(&p.path("out/curves.parquet")).unwrap();
    let posed: Vec<usize> = (0..out.script.len()).filter(|&r| out.script[r] == reprise_retarget_apply::POSED).collect();
    assert_eq!(posed.len(), 2);
    let col = |name: &str| out.controls.iter().position(|c| c == name).unwrap();
    let value = |r: usize, name: &str| out.values[r * out.controls.len() + col(name)];
    assert!((value(posed[0], "jaw_open") - 30.0).abs() < 0.5 && (value(posed[0], "smile_L") - 0.6).abs() < 0.05);
    assert!((value(posed[1], "lip_pucker") - 0.7).abs() < 0.05);
    // The unfixed controls are filled in from the training poses, not left at rest: the
    // shape the jaw's opening drives moves with it.
    assert!(value(posed[0], "jaw_open_shape") > value(posed[1], "jaw_open_shape") + 0.05);
    assert!(p.read("out/r.md").contains("`jaw_open` = 30"));
    // A control the corpus never moves cannot be fixed.
    let err = apply(&["--pose", "tweak_snout_tx=1"]).fails(exit::CONFIG);
    assert!(err.contains("`tweak_snout_tx` has no weight"), "{err}");
}

/// A tiny capture (3 markers), corpus (2 controls) and pairs, written as a user would.
fn tiny(p: &Project) {
    let prov = Provenance::new("test", "0", serde_json::json!({}));
    let n = 40;
    let t = |f: usize| f as f64 / 10.0;
    let capture = Positions {
        fps: 30.0,
        points: vec![0, 1, 2],
        clip: vec!["take".into(); n],
        frame: (0..n as i64).collect(),
        values: (0..n).flat_map(|f| [t(f).sin(), 0.0, 0.0, 1.0, t(f).cos(), 0.0, 0.0, 1.0, 0.3 * t(f)]).collect(),
    };
    capture.write(&p.path("capture.parquet"), &prov).unwrap();
    let frames = |rows: &[usize], clip: &str| Frames {
        fps: 30.0,
        controls: vec!["a".into(), "b".into()],
        clip: vec![clip.into(); rows.len()],
        frame: rows.iter().map(|&r| r as i64).collect(),
        time: rows.iter().map(|&r| r as f64 / 30.0).collect(),
        values: rows.iter().flat_map(|&r| [t(r).sin() * 2.0, t(r) * t(r)]).collect(),
    };
    frames(&(0..n).collect::<Vec<_>>(), "corpus").write(&p.path("corpus.parquet"), &prov).unwrap();
    frames(&[0, 10, 20, 30], "take").write(&p.path("pairs.parquet"), &prov).unwrap();
    let scale = |c: &str| Scale {
        label: "all".into(),
        control: c.into(),
        mean: 0.0,
        std: 1.0,
        weight: 1.0,
        residual: 0.0,
        used: true,
        reason: String::new(),
    };
    scales::write(&p.path("scales.parquet"), &[scale("a"), scale("b")], &prov).unwrap();
}

fn fit(p: &Project, pairs: &str) -> crate::util::Run {
    p.stage(
        "reprise-retarget-fit",
        &[
            "--capture",
            "capture.parquet",
            "--pairs",
            pairs,
            "--corpus",
            "corpus.parquet",
            "--scales",
            "scales.parquet",
            "--model",
            "out/model.parquet",
            "--capture-noise",
            "0.01",
            "--source-frames",
            "20",
            "--target-poses",
            "10",
            "--iterations",
            "50",
        ],
    )
}

#[test]
fn bad_pairs_captures_and_values_are_named() {
    let p = Project::empty();
    tiny(&p);
    let prov = Provenance::new("test", "0", serde_json::json!({}));

    // A pair naming a capture frame that does not exist.
    let mut pairs = Frames::read(&p.path("pairs.parquet")).unwrap();
    pairs.frame[3] = 99;
    pairs.write(&p.path("missing.parquet"), &prov).unwrap();
    let err = fit(&p, "missing.parquet").fails(exit::INPUT);
    assert!(err.contains("missing.parquet") && err.contains("row 3") && err.contains("frame 99"), "{err}");
    assert!(!p.path("out/model.parquet").exists(), "nothing written on bad input");

    // A NaN in a pair's pose, written as a user's tool might.
    let cols = Columns::new()
        .str("clip", &["take", "take"])
        .i64("frame", vec![0, 10])
        .f64("time", vec![0.0, 1.0 / 3.0])
        .f64_any("a", vec![0.0, f64::NAN])
        .f64("b", vec![0.0, 0.1]);
    reprise_artifact::table::write(
        &p.path("nan.parquet"),
        reprise_artifact::frames::FRAMES,
        cols,
        &prov,
        &[("reprise.fps".into(), "30".into())],
    )
    .unwrap();
    let err = fit(&p, "nan.parquet").fails(exit::INPUT);
    assert!(err.contains("nan.parquet") && err.contains("`a`") && err.contains("row 1"), "{err}");

    // A good fit, then a capture of other markers than the model's.
    fit(&p, "pairs.parquet").ok();
    let mut other = Positions::read(&p.path("capture.parquet"), None).unwrap();
    other.points = vec![0, 1, 5];
    other.write(&p.path("other.parquet"), &prov).unwrap();
    p.write("controls.parquet", "");
    let err = p
        .stage(
            "reprise-retarget-apply",
            &[
                "--model",
                "out/model.parquet",
                "--capture",
                "other.parquet",
                "--controls",
                "controls.parquet",
                "--curves",
                "out/c.parquet",
                "--frames",
                "out/f.parquet",
                "--glb",
                "out/r.glb",
                "--report",
                "out/r.md",
                "--player",
                "out/r.html",
            ],
        )
        .fails(exit::INPUT);
    assert!(err.contains("other.parquet") && err.contains("first differ at position 2"), "{err}");
    assert!(!p.path("out/c.parquet").exists());
}
