//! `reprise replay` (#29): a live session's recording, built in process on a real
//! (short-fitted) dragon-face pipeline, measured by the benchmark's `evaluate` for every
//! system — not only those the session ran; a system that cannot reach a label is counted
//! unanswered, saying why; a user's file in the way and bad recordings are refused, naming
//! the file.

use std::collections::BTreeSet;

use reprise_artifact::transitions;
use reprise_live::command::LiveCommand;
use reprise_live::session::Session;
use reprise_live::world::{Paths, Tuning, World};

use crate::util::Project;

/// The dragon-face pipeline with short fits, run as far as `replay` needs: the benchmark's
/// inputs (`transitions`) and the rest of what `evaluate` reads (`synthesize`'s curves).
fn fitted() -> Project {
    let p = Project::dragon_face();
    let short = [
        ("max_iters = 10000", "max_iters = 10"),
        ("stride = 1", "stride = 5"),
        ("heldout_every = 10", "heldout_every = 0"),
    ];
    let toml = short.iter().fold(p.read("pipeline.toml"), |t, (from, to)| t.replace(from, to));
    p.write("pipeline.toml", &toml);
    for stage in ["transitions", "synthesize"] {
        p.reprise(&["run", "--to", stage]).ok();
    }
    p
}

/// The session: reprise and the crossfade from `neutral`, TRANSITION to roar, an IDLE,
/// TRANSITION to happy, TRANSITION to roar.
const COMMANDS: [(usize, &str); 4] = [
    (10, r#"{"type":"transition","to":"roar"}"#),
    (80, r#"{"type":"idle"}"#),
    (90, r#"{"type":"transition","to":"happy"}"#),
    (160, r#"{"type":"transition","to":"roar"}"#),
];

#[test]
fn a_recorded_session_is_measured_for_every_system() {
    let p = fitted();
    let world = World::load(&Paths::in_dir(&p.path("artifacts/dragon-face")), Tuning::default()).unwrap();
    let systems = vec!["reprise".to_string(), "crossfade".to_string()];
    let mut s = Session::new(world, &systems, "neutral", 5).unwrap();
    for f in 0..230 {
        for (at, text) in COMMANDS {
            if at == f {
                s.command(LiveCommand::parse(text, &world.labels).unwrap()).unwrap();
            }
        }
        s.step();
    }
    let recording = reprise_serve::record::write(&p.path("recordings"), s.recording()).unwrap();
    let stem = recording.file_stem().unwrap().to_string_lossy().into_owned();
    let out = p.reprise(&["replay", &recording.to_string_lossy()]).ok();
    let report = p.path(&format!("reports/dragon-face/replay-{stem}"));
    assert!(out.contains(&format!("replay-{stem}/index.html")), "the last line names the report:\n{out}");
    for file in ["index.html", "report.md", "metrics.parquet"] {
        assert!(report.join(file).is_file(), "{file} in {}", report.display());
    }

    // One request per TRANSITION, each from the label asked before it.
    let art = p.path(&format!("artifacts/dragon-face/replay-{stem}"));
    let reqs = transitions::read_requests(&art.join("transition_requests.parquet")).unwrap();
    let asked: Vec<(&str, &str)> = reqs.iter().map(|r| (r.from.as_str(), r.to.as_str())).collect();
    assert_eq!(asked, [("neutral", "roar"), ("roar", "happy"), ("happy", "roar")]);

    // Every system is measured, the session's and the others.
    let metrics = reprise_evaluate::read_metrics(&report.join("metrics.parquet")).unwrap();
    let answered = |system: &str| {
        let m = metrics.iter().find(|m| m.system == system && m.metric == "answered" && m.from == "all");
        m.unwrap_or_else(|| panic!("no `answered` of {system}")).value
    };
    let measured: BTreeSet<&str> = metrics.iter().map(|m| m.system.as_str()).collect();
    for def in reprise_benchmark::systems::SYSTEMS {
        assert!(measured.contains(def.id), "{} has metrics: {measured:?}", def.id);
        let a = transitions::read_answers(&art.join(format!("answers_{}.parquet", def.id.replace('-', "_")))).unwrap();
        assert_eq!(a.by_request.len(), 3, "{}: one answer per request", def.id);
        if def.id != "motion-graphs" {
            assert!(a.get(0).unwrap().latency.is_some(), "{} reaches roar: {:?}", def.id, a.get(0));
        }
        let overall = |metric: &str| {
            metrics.iter().find(|m| m.system == def.id && m.metric == metric && m.from == "all").map(|m| m.value)
        };
        eprintln!(
            "{:16} answered {:.3}  arrived {:?}  perceived latency {:?} s  switch latency {:?} s",
            def.id,
            answered(def.id),
            overall("arrived"),
            overall("perceived_latency_s"),
            overall("switch_latency_s")
        );
    }
    // Motion Graphs cannot reach roar on this corpus: both requests into roar are unanswered,
    // in its own words; the one into happy is answered.
    let mg = transitions::read_answers(&art.join("answers_motion_graphs.parquet")).unwrap();
    for r in [0, 2] {
        let e = &mg.get(r).unwrap().error;
        assert!(mg.get(r).unwrap().latency.is_none(), "request {r}");
        assert!(e.contains("never showed `roar`") && e.contains("no path to `roar`"), "request {r}: {e}");
    }
    assert!(mg.get(1).unwrap().latency.is_some(), "Motion Graphs reaches happy");
    assert!((answered("motion-graphs") - 1.0 / 3.0).abs() < 1e-9, "{}", answered("motion-graphs"));

    // Again: its own files are replaced. A user's file in the way is refused and kept.
    p.reprise(&["replay", &recording.to_string_lossy()]).ok();
    let mine = p.path("recordings/mine.json");
    std::fs::copy(&recording, &mine).unwrap();
    p.write("reports/dragon-face/replay-mine/index.html", "my notes");
    let e = p.reprise(&["replay", "recordings/mine.json"]).fails(2);
    assert!(e.contains("reports/dragon-face/replay-mine/index.html") && e.contains("refusing to overwrite"), "{e}");
    assert_eq!(p.read("reports/dragon-face/replay-mine/index.html"), "my notes");

    // Bad recordings are refused, naming the file.
    let text = std::fs::read_to_string(&recording).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let with = |key: &str, value: serde_json::Value| {
        let mut j = json.clone();
        j[key] = value;
        j.to_string()
    };
    let mut late_first = json["commands"].clone();
    late_first[0]["frame"] = serde_json::json!(200);
    let bad = [
        ("not-json", "{\"systems\": 1".to_string(), "not a session recording"),
        ("stranger", with("systems", serde_json::json!(["nobody"])), "unknown system `nobody`"),
        (
            "sneeze",
            with("commands", serde_json::json!([{"frame": 3, "command": {"type": "transition", "to": "sneeze"}}])),
            "unknown label `sneeze`",
        ),
        ("shuffled", with("commands", late_first), "not in frame order"),
    ];
    for (name, body, why) in bad {
        p.write(&format!("recordings/{name}.json"), &body);
        let e = p.reprise(&["replay", &format!("recordings/{name}.json")]).fails(3);
        assert!(e.contains(&format!("recordings/{name}.json")) && e.contains(why), "{name}: {e}");
    }
}
