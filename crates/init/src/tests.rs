//! Unit tests of the labels plan, names and the demo script.

use std::collections::BTreeMap;

use reprise_artifact::segments::Segment;

use crate::{plan_labels, script_text, slug, ClipInfo, Fate};

fn clip(name: &str, frames: i64) -> ClipInfo {
    ClipInfo { name: name.into(), frames }
}

/// Long clips are their own labels, named after them (distinct even when two names slug
/// alike); short clips share a label by the first word of their names when together
/// long enough, else are excluded with the reason; a clip name with glob characters
/// becomes a whole-clip range.
#[test]
fn labels_one_per_clip_short_ones_grouped_or_excluded() {
    let clips = [
        clip("Idle", 100),
        clip("Walk Cycle", 40),
        clip("walk-cycle", 30),
        clip("emote-yes", 17),
        clip("emote-no", 17),
        clip("Sit", 11),
        clip("[x]", 24),
        clip("idle-blink", 5),
    ];
    let plan = plan_labels(&clips, 24, &BTreeMap::new()).unwrap();
    assert_eq!(plan.labels(), ["idle", "walk_cycle", "walk_cycle_2", "emote", "x"]);
    let fate = |name: &str| plan.clips.iter().find(|(c, _)| c.name == name).unwrap().1.clone();
    assert_eq!(fate("emote-no"), Fate::Grouped("emote".into()));
    assert_eq!(fate("idle-blink"), Fate::Grouped("idle".into()), "joins the clip label of its word");
    assert!(matches!(fate("Sit"), Fate::Excluded(why) if why.contains("11 frames: too short")));
    let parsed: toml::Table = toml::from_str(&plan.text).unwrap();
    assert_eq!(parsed["rule"].as_array().unwrap().len(), 6);
    assert_eq!(parsed["range"][0]["clip"].as_str(), Some("[x]"));
    assert_eq!(parsed["range"][0]["end"].as_integer(), Some(23));
    assert_eq!(parsed["exclude"][0]["clip"].as_str(), Some("Sit"));
    assert!(plan.text.contains("share a label with the clips"), "{}", plan.text);

    // A label that cannot be modeled is excluded with its reason.
    let thin = BTreeMap::from([("idle".to_string(), "moves in 2 dimension(s)".to_string())]);
    let plan = plan_labels(&clips, 24, &thin).unwrap();
    assert!(!plan.labels().contains(&"idle"));
    let parsed: toml::Table = toml::from_str(&plan.text).unwrap();
    let reasons: Vec<&str> =
        parsed["exclude"].as_array().unwrap().iter().filter_map(|e| e["reason"].as_str()).collect();
    assert_eq!(reasons.iter().filter(|r| r.contains("its label `idle` moves in 2")).count(), 2, "{reasons:?}");
}

#[test]
fn fewer_than_two_labels_is_an_error_naming_the_clips() {
    let e = plan_labels(&[clip("Take", 200), clip("Blink", 5)], 24, &BTreeMap::new()).unwrap_err().to_string();
    assert!(e.contains("make 1 label(s)") && e.contains("`Blink` (5 frames)"), "{e}");
    assert!(e.contains("--labels") && e.contains("`[[range]]` table per part (`clip = \"Take\"`"), "{e}");
}

/// An excluded clip's reason says what it could have shared: the other short clips of
/// its word (too short together), the long clips of its word (labels of their own), or
/// nothing.
#[test]
fn an_excluded_clip_says_what_it_could_share() {
    let clips = [clip("Jump_Start", 40), clip("Jump_Land", 6), clip("Jump_Air", 5), clip("Wave", 30), clip("Blink", 3)];
    let plan = plan_labels(&clips, 24, &BTreeMap::new()).unwrap();
    let why = |name: &str| match &plan.clips.iter().find(|(c, _)| c.name == name).unwrap().1 {
        Fate::Excluded(why) => why.clone(),
        other => panic!("{name}: {other:?}"),
    };
    let land = why("Jump_Land");
    assert!(land.contains("with the 1 other short clip(s) whose names start with `jump` it has 11 frames"), "{land}");
    assert!(land.contains("have labels of their own (`jump_start`)"), "{land}");
    assert!(!land.contains("no other clip"), "{land}");
    assert!(why("Blink").contains("no other clip's name starts with `blink`"));
}

#[test]
fn names_are_slugs() {
    assert_eq!(slug("character-male-a", '-'), "character-male-a");
    assert_eq!(slug("  Robot Expressive!", '-'), "robot-expressive");
    assert_eq!(slug("***", '-'), "");
}

fn segment(id: i64, label: &str, clip: &str, start: i64, end: i64) -> Segment {
    Segment { segment_id: id, label: label.into(), clip: clip.into(), start, end }
}

/// The script starts on the first label's longest segment and plays its clip.
#[test]
fn the_demo_script_names_real_frames() {
    let segs =
        [segment(0, "idle", "Idle", 0, 10), segment(1, "idle", "Idle2", 5, 60), segment(2, "wave", "Wave", 0, 30)];
    let text = script_text(&segs).unwrap();
    let parsed: toml::Table = toml::from_str(&text).unwrap();
    let script = &parsed["script"][0];
    assert_eq!(script["start"]["clip"].as_str(), Some("Idle2"));
    assert_eq!(script["start"]["frame"].as_integer(), Some(5));
    assert_eq!(script["command"][1]["clip"].as_str(), Some("Idle2"));
    assert!(text.contains("# to = \"wave\""), "{text}");
    assert!(script_text(&[]).is_err());
}

/// The game file reads with the game's own parser against the character's labels: every
/// event reacts, the labels are taken in turn, and the game-ending events also play the
/// label's longest take.
#[test]
fn the_game_file_reads_and_names_the_labels() {
    use reprise_live::game::{Event, GameFile};
    let segs =
        [segment(0, "idle", "Idle", 0, 10), segment(1, "idle", "Idle2", 5, 60), segment(2, "wave", "Wave", 0, 30)];
    let text = crate::template::game_text(&segs).unwrap();
    let game =
        GameFile::parse(&text, &["idle".to_string(), "wave".to_string()]).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let to = |e: Event| game.scripts(e)[0].steps[0].command.label().map(str::to_string);
    assert_eq!(to(Event::PlayerTurn).as_deref(), Some("idle"));
    assert_eq!(to(Event::Ponder).as_deref(), Some("wave"));
    assert_eq!(to(Event::Win).as_deref(), Some("idle"));
    assert_eq!(game.scripts(Event::Win).len(), 2);
    assert!(text.contains("clip = \"Idle2\""), "{text}");
    assert_eq!(game.scripts(Event::Ponder).len(), 1);
    // A label set without the file's labels is refused by the parser, naming one.
    assert!(GameFile::parse(&text, &["other".to_string()]).is_err());
    assert!(crate::template::game_text(&[]).is_err());
}
