//! `reprise init` then `reprise run`: a new character's pipeline written from its source
//! alone runs to the report with no hand edits — on BVH takes made here (a glob), and on
//! the Kenney glTF character from `../shared` when it is there. And what `status` says
//! about one label's frames changing.

use std::f64::consts::PI;
use std::fmt::Write as _;

use crate::util::{shared_dataset, Project};

/// A BVH take of a four-joint chain at 30 fps: `frames` frames, each joint turning about
/// its own axes with its own rate (`speed` scales them all), so a take moves in more
/// dimensions than the GPLVM's three.
fn take(frames: usize, speed: f64) -> String {
    let mut t = String::from("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n");
    for joint in ["Spine", "Neck", "Head"] {
        let _ = writeln!(t, "  JOINT {joint}\n  {{\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation");
    }
    t.push_str("    End Site\n    {\n      OFFSET 0 5 0\n    }\n");
    for _ in 0..3 {
        t.push_str("  }\n");
    }
    let _ = write!(t, "}}\nMOTION\nFrames: {frames}\nFrame Time: 0.0333333\n");
    for f in 0..frames {
        let s = f as f64 / 30.0 * speed;
        let mut row = vec![(2.0 * PI * 0.3 * s).sin(), 0.0, (2.0 * PI * 0.2 * s).cos()];
        for j in 0..4 {
            let k = j as f64 + 1.0;
            row.extend([
                20.0 * (2.0 * PI * 0.5 * k * s).sin(),
                15.0 * (2.0 * PI * 0.7 * k * s + k).cos(),
                10.0 * (2.0 * PI * 0.3 * k * s + 2.0 * k).sin(),
            ]);
        }
        let line: Vec<String> = row.iter().map(|v| format!("{v:.5}")).collect();
        let _ = writeln!(t, "{}", line.join(" "));
    }
    t
}

/// Three takes and a blip too short to model, given as a glob: `init` writes the pipeline,
/// a label per take (the blip excluded, saying why) and a demo script; `run` makes the
/// report; a second `init` refuses to overwrite, `--force` rewrites the same files and
/// nothing reruns; a new take matching the glob makes ingest stale, named.
#[test]
fn init_on_bvh_takes_then_run_makes_a_report() {
    let p = Project::empty();
    for (name, frames, speed) in [("wave", 72, 1.0), ("nod", 60, 1.7), ("spin", 66, 0.6), ("blip", 12, 1.0)] {
        p.write(&format!("takes/{name}.bvh"), &take(frames, speed));
    }
    let said = p.reprise(&["init", "--bvh", "takes/*.bvh"]).ok();
    assert!(said.contains("wrote pipeline.toml") && said.contains("next: reprise run"), "{said}");
    let pipeline = p.read("pipeline.toml");
    assert!(pipeline.contains("inputs.bvh = \"takes/*.bvh\"") && pipeline.contains("name = \"takes\""), "{pipeline}");
    assert!(!pipeline.contains("export-gltf"), "a BVH skeleton has no glTF to export into");
    let labels = p.read("labels.toml");
    for take in ["wave", "nod", "spin"] {
        assert!(labels.contains(&format!("pattern = \"{take}\"\nlabel = \"{take}\"")), "{labels}");
    }
    assert!(labels.contains("clip = \"blip\"\nreason = \"9 frames: too short to model"), "{labels}");
    assert!(said.contains("`blip` excluded"), "{said}");
    assert!(p.read("scripts/demo.toml").contains("type = \"play\""));

    let run = p.reprise(&["run"]).ok();
    assert!(run.contains("finished 11 ran, 0 cached"), "{run}");
    assert!(p.read("reports/takes/report.md").contains("## Conclusions"));
    assert!(p.path("reports/takes/index.html").exists());
    // The skeleton character live: bone lines on the page, every system, its game.
    crate::live::serve_smoke(&p);

    let refused = p.reprise(&["init", "--bvh", "takes/*.bvh"]).fails(2);
    assert!(refused.contains("pipeline.toml` exists; refusing to overwrite it (give --force"), "{refused}");
    p.reprise(&["init", "--bvh", "takes/*.bvh", "--force"]).ok();
    assert!(p.reprise(&["run"]).ok().contains("all 11 stages are up to date"));

    // Excluding frames from the middle of one take: the stages after label see which
    // label's rows changed (the other labels' segments are renumbered, not changed).
    let labels = p.read("labels.toml");
    p.write("labels.toml", &format!("{labels}[[exclude]]\nclip = \"nod\"\nstart = 20\nend = 23\n"));
    p.reprise(&["run", "--to", "label"]).ok();
    let status = p.reprise(&["status"]).ok();
    assert!(
        status.contains(
            "input `labeled_frames` changed (artifacts/takes/labeled_frames.parquet): label `nod` changed; 2 label(s) \
             unchanged"
        ),
        "{status}"
    );

    p.write("takes/turn.bvh", &take(48, 1.3));
    let status = p.reprise(&["status"]).ok();
    assert!(status.contains("input `bvh[4]` added (takes/wave.bvh)"), "{status}");
}

/// What init cannot make work is refused before anything is written, saying what to give.
#[test]
fn init_refuses_sources_it_cannot_make_a_pipeline_of() {
    let p = Project::empty();
    p.write("one.bvh", &take(90, 1.0));
    let e = p.reprise(&["init", "--bvh", "one.bvh"]).fails(2);
    assert!(e.contains("make 1 label(s)") && e.contains("`one` (72 frames)") && e.contains("--labels"), "{e}");
    p.write("curves.csv", "clip,frame,a\nx,0,1\n");
    let e = p.reprise(&["init", "--curves", "curves.csv"]).fails(2);
    assert!(e.contains("a curve table carries no rig") && e.contains("--external-rig"), "{e}");
    let e = p.reprise(&["init", "--gltf", "missing.glb"]).fails(2);
    assert!(e.contains("--gltf `missing.glb`: no such file"), "{e}");
    let e = p.reprise(&["init", "--bvh", "takes/*.bvh"]).fails(2);
    assert!(e.contains("--bvh `takes/*.bvh`: cannot list"), "{e}");
    p.write("labels.toml", "[[rule]]\npattern = \"nothing*\"\nlabel = \"x\"\n");
    let e = p.reprise(&["init", "--bvh", "one.bvh", "--labels", "labels.toml"]).fails(3);
    assert!(e.contains("checking the source, stage `label` failed") && e.contains("labels.toml"), "{e}");
    assert!(!p.path("pipeline.toml").exists() && !p.path("scripts").exists(), "nothing written");
    p.reprise(&["init", "--bvh", "one.bvh", "--pipeline", "new/dir/pipeline.toml"]).fails(2);
    assert!(!p.path("new/dir").exists(), "a directory made for the pipeline goes when init fails");

    // Into a directory of its own, with a list of takes: paths relative to the pipeline.
    p.write("two.bvh", &take(60, 1.5));
    p.reprise(&["init", "--bvh", "one.bvh", "two.bvh", "--pipeline", "new/dir/pipeline.toml"]).ok();
    let pipeline = p.read("new/dir/pipeline.toml");
    assert!(pipeline.contains("inputs.bvh = [\"../../one.bvh\", \"../../two.bvh\"]"), "{pipeline}");
    assert!(p.path("new/dir/labels.toml").exists() && p.path("new/dir/scripts/demo.toml").exists());
    let dag = p.reprise(&["dag", "--pipeline", "new/dir/pipeline.toml"]).ok();
    assert!(dag.contains("<- bvh[1]: ../../two.bvh (source file)"), "{dag}");
}

/// The done-when: the Kenney character from its file alone to the report.
#[test]
fn init_on_the_kenney_character_then_run_makes_a_report() {
    let Some(glb) = shared_dataset(
        "init_on_the_kenney_character_then_run_makes_a_report",
        "kenney_mini_characters/character-male-a.glb",
    ) else {
        return;
    };
    let p = Project::empty();
    let said = p.reprise(&["init", "--gltf", &glb.display().to_string()]).ok();
    assert!(said.contains("shares label `wheelchair`") && said.contains("`static` excluded"), "{said}");
    p.reprise(&["run"]).ok();
    assert!(p.read("reports/character-male-a/report.md").contains("## Conclusions"));
    assert!(p.path("artifacts/character-male-a/exported.glb").exists());
    crate::live::serve_smoke(&p);
}

/// A curve table with its rig evaluator: init passes the evaluator to ingest, and the
/// pipeline runs to the report.
#[test]
fn init_on_a_curve_table_with_an_external_rig_then_run_makes_a_report() {
    let p = Project::empty();
    let mut csv = String::from("clip,frame,c0,c1,c2,c3,c4,c5\n");
    for (clip, rate) in [("calm", 0.4), ("busy", 1.3)] {
        for f in 0..60 {
            let s = f64::from(f) / 24.0 * rate;
            let values: Vec<String> = (0..6)
                .map(|c| format!("{:.5}", (2.0 * PI * (0.5 + 0.3 * f64::from(c)) * s + f64::from(c)).sin()))
                .collect();
            let _ = writeln!(csv, "{clip},{f},{}", values.join(","));
        }
    }
    p.write("curves.csv", &csv);
    let rig = format!("{},--vertices,7", env!("CARGO_BIN_EXE_reprise-example-rig"));
    p.reprise(&["init", "--curves", "curves.csv", "--external-rig", &rig]).ok();
    assert!(p.read("pipeline.toml").contains("external_rig = ["), "{}", p.read("pipeline.toml"));
    p.reprise(&["run"]).ok();
    assert!(p.read("reports/curves/report.md").contains("## Conclusions"));
}
