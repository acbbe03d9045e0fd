//! The labels file `init` writes when none is given: one label per clip long enough to
//! model, short clips grouped by the first word of their names or excluded, saying why.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use reprise_runner::error::{Error, Result};

use crate::slug;
use crate::template::quoted;

/// One clip of the source: its name and frame count at the pipeline's rate.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClipInfo {
    /// The clip's name.
    pub name: String,
    /// Frames after resampling.
    pub frames: i64,
}

/// What the generated labels file does with one clip.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fate {
    /// Its own label.
    Own(String),
    /// A label shared with the other short clips whose names start with the same word.
    Grouped(String),
    /// Excluded, and why.
    Excluded(String),
}

/// A generated labels file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabelsPlan {
    /// The file's text.
    pub text: String,
    /// Each clip and what became of it, in clip order.
    pub clips: Vec<(ClipInfo, Fate)>,
}

impl LabelsPlan {
    /// The distinct labels, in order of first use.
    #[must_use]
    pub fn labels(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for (_, fate) in &self.clips {
            if let Fate::Own(l) | Fate::Grouped(l) = fate {
                if !out.contains(&l.as_str()) {
                    out.push(l);
                }
            }
        }
        out
    }
}

/// Labels for `clips`: a clip of at least `min_frames` frames is its own label, named
/// after it; shorter clips whose names start with the same word share a label named by
/// that word when they have `min_frames` together (or join a clip's label of that name);
/// the rest are excluded, as are the clips of every label in `thin` (label → why). The
/// file says, in comments and reasons, what was grouped or excluded and why. Fewer than
/// two labels is an error: bridges and the benchmark need two.
pub fn plan_labels(clips: &[ClipInfo], min_frames: i64, thin: &BTreeMap<String, String>) -> Result<LabelsPlan> {
    let mut fates: Vec<Fate> = Vec::with_capacity(clips.len());
    let mut own: Vec<String> = Vec::new();
    for clip in clips {
        if clip.frames < min_frames {
            fates.push(Fate::Excluded(String::new()));
            continue;
        }
        let base = Some(slug(&clip.name, '_')).filter(|s| !s.is_empty()).unwrap_or_else(|| "clip".into());
        let mut label = base.clone();
        let mut n = 2;
        while own.contains(&label) {
            label = format!("{base}_{n}");
            n += 1;
        }
        own.push(label.clone());
        fates.push(Fate::Own(label));
    }
    let word = |name: &str| slug(name, '_').split('_').find(|w| !w.is_empty()).unwrap_or("clip").to_string();
    let mut words: Vec<(String, i64)> = Vec::new();
    for (clip, fate) in clips.iter().zip(&fates) {
        if matches!(fate, Fate::Excluded(_)) {
            let w = word(&clip.name);
            match words.iter_mut().find(|(x, _)| *x == w) {
                Some((_, total)) => *total += clip.frames,
                None => words.push((w, clip.frames)),
            }
        }
    }
    let long_by_word: Vec<(String, String)> = clips
        .iter()
        .zip(&fates)
        .filter_map(|(c, f)| if let Fate::Own(l) = f { Some((word(&c.name), l.clone())) } else { None })
        .collect();
    let short_by_word = |w: &str| {
        clips.iter().zip(&fates).filter(|(c, f)| matches!(f, Fate::Excluded(_)) && word(&c.name) == w).count()
    };
    let mut decided = Vec::with_capacity(fates.len());
    for (clip, fate) in clips.iter().zip(&fates) {
        if !matches!(fate, Fate::Excluded(_)) {
            decided.push(fate.clone());
            continue;
        }
        let w = word(&clip.name);
        let total = words.iter().find(|(x, _)| *x == w).map_or(0, |(_, t)| *t);
        if own.contains(&w) || total >= min_frames {
            decided.push(Fate::Grouped(w));
            continue;
        }
        let mut why = format!("{} frames: too short to model (a label needs at least {min_frames})", clip.frames);
        let others = short_by_word(&w) - 1;
        if others > 0 {
            let _ = write!(
                why,
                "; with the {others} other short clip(s) whose names start with `{w}` it has {total} frames, still fewer"
            );
        }
        let long: Vec<String> = long_by_word.iter().filter(|(x, _)| *x == w).map(|(_, l)| format!("`{l}`")).collect();
        if !long.is_empty() {
            let _ = write!(
                why,
                "; the long clips whose names start with `{w}` have labels of their own ({}): to keep it, give it one of \
                 them in the labels file",
                long.join(", ")
            );
        }
        if others == 0 && long.is_empty() {
            let _ = write!(why, ", and no other clip's name starts with `{w}` to share a label with");
        }
        decided.push(Fate::Excluded(why));
    }
    let mut fates = decided;
    for fate in &mut fates {
        if let Fate::Own(l) | Fate::Grouped(l) = fate {
            if let Some(why) = thin.get(l.as_str()) {
                *fate = Fate::Excluded(format!("its label `{l}` {why}"));
            }
        }
    }
    let plan =
        LabelsPlan { text: labels_text(clips, &fates, min_frames), clips: clips.iter().cloned().zip(fates).collect() };
    let labels = plan.labels();
    if labels.len() < 2 {
        let list: Vec<String> = clips.iter().map(|c| format!("`{}` ({} frames)", c.name, c.frames)).collect();
        return Err(Error::Init(format!(
            "the source's clips make {} label(s) that can be modeled ({}); a pipeline needs two to bridge and \
             compare: write a labels file that splits the takes into labels by frame ranges, one \
             `[[range]]` table per part (`clip = \"{}\"`, `start = 0`, `end = 119`, `label = \"…\"`, frames \
             inclusive; docs/inputs.md, \"Labels file\"), and give it with --labels",
            labels.len(),
            list.join(", "),
            clips.iter().max_by_key(|c| c.frames).map_or("", |c| c.name.as_str())
        )));
    }
    Ok(plan)
}

/// The labels file for `fates` (see [`plan_labels`]).
fn labels_text(clips: &[ClipInfo], fates: &[Fate], min_frames: i64) -> String {
    let mut t = String::from(
        "# Labels written by `reprise init`. Edit them: the paper groups frames by what the motion\n\
         # communicates, so that each label's model is homogeneous (`pattern` is a glob over clip\n\
         # names; several clips may share a label). Format: docs/inputs.md, \"Labels file\".\n",
    );
    let entry = |t: &mut String, clip: &ClipInfo, label: &str| {
        if reprise_runner::paths::is_glob(&clip.name) {
            let _ = writeln!(
                t,
                "[[range]]\nclip = {}\nstart = 0\nend = {}\nlabel = {}",
                quoted(&clip.name),
                clip.frames - 1,
                quoted(label)
            );
        } else {
            let _ = writeln!(t, "[[rule]]\npattern = {}\nlabel = {}", quoted(&clip.name), quoted(label));
        }
    };
    let own: fn(&Fate) -> Option<&str> = |f| if let Fate::Own(l) = f { Some(l) } else { None };
    let grouped: fn(&Fate) -> Option<&str> = |f| if let Fate::Grouped(l) = f { Some(l) } else { None };
    let sections = [
        (format!("One label per clip of at least {min_frames} frames."), own),
        (
            format!(
                "Clips shorter than {min_frames} frames, too short to model alone, share a label with the clips\n\
                 # whose names start with the same word."
            ),
            grouped,
        ),
    ];
    for (heading, pick) in sections {
        let members: Vec<(&ClipInfo, &str)> =
            clips.iter().zip(fates).filter_map(|(c, f)| Some((c, pick(f)?))).collect();
        if !members.is_empty() {
            let _ = writeln!(t, "\n# {heading}");
        }
        for (clip, label) in members {
            let _ = writeln!(t, "# {}: {} frames", clip.name, clip.frames);
            entry(&mut t, clip, label);
        }
    }
    if fates.iter().any(|f| matches!(f, Fate::Excluded(_))) {
        let _ = writeln!(
            t,
            "\n# Excluded: each reason says why. To keep a clip, give it the label of clips it moves like."
        );
        for (clip, fate) in clips.iter().zip(fates) {
            if let Fate::Excluded(why) = fate {
                let _ = writeln!(t, "[[exclude]]\nclip = {}\nreason = {}", quoted(&clip.name), quoted(why));
            }
        }
    }
    t
}
