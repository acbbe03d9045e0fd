//! A recording as the transition benchmark sees it: each TRANSITION command is a request,
//! and a system's frames around it are its answer. No I/O and no systems: the frames are
//! given as labels (and notes), so the rules can be checked on sequences whose answers are
//! known.
//!
//! **The played sequence.** A system's frames are indexed with the session's start frame
//! first: index 0 is the labeled frame every system starts from ([`World::start_row`] of
//! the start label), index $i + 1$ is the session's frame $i$. A command stamped frame $f$
//! reaches the systems before they make frame $f$ (index $f + 1$), so index $f$ is the last
//! frame before it — the request's `asked` frame, as in the benchmark, where the frames up
//! to `asked` are context and only those after it are measured. (The start frame is what
//! makes a command stamped frame 0 measurable like any other.)
//!
//! [`World::start_row`]: reprise_live::world::World::start_row

use reprise_artifact::transitions::Answer;
use reprise_live::session::Recording;

/// One TRANSITION command of a recording, as a request of the benchmark.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Asked {
    /// Its id: the TRANSITION commands counted in the recording's order, from 0.
    pub request: i64,
    /// Label A: the label the TRANSITION before it went to, or the session's start label.
    pub from: String,
    /// Label B: the label it goes to.
    pub to: String,
    /// The frame it was stamped (it reached the systems before they made this frame).
    pub frame: usize,
    /// Where its answer ends: the stamp of the next command of any kind (which changes what
    /// the systems do), or the recording's length.
    pub until: usize,
    /// Whether a next command ended it (otherwise the recording's end did).
    pub cut: bool,
}

/// Where a request's curve lies in a system's played sequence (see the module docs):
/// indices `first..end`, the request asked at index `asked`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// The curve's first frame.
    pub first: usize,
    /// The last frame before the command.
    pub asked: usize,
    /// One past the curve's last frame.
    pub end: usize,
}

impl Window {
    /// `asked` counted from the curve's first frame: the answer's `asked`.
    pub fn asked_in_curve(&self) -> usize {
        self.asked - self.first
    }

    /// Frames in the curve.
    pub fn len(&self) -> usize {
        self.end - self.first
    }

    /// Whether the curve has no frame (never: it holds at least the asked frame).
    pub fn is_empty(&self) -> bool {
        self.end == self.first
    }
}

/// The requests of `rec`: one per TRANSITION command, in the recording's order (the
/// recording's own checks — commands in frame order, labels known — are
/// `reprise_live::session::replay`'s).
pub fn asked(rec: &Recording) -> Vec<Asked> {
    let mut from = rec.start.clone();
    let mut out = Vec::new();
    for (i, c) in rec.commands.iter().enumerate() {
        let Some(to) = c.command.label() else { continue };
        let next = rec.commands.get(i + 1).map(|n| n.frame);
        out.push(Asked {
            request: out.len() as i64,
            from: std::mem::replace(&mut from, to.to_string()),
            to: to.to_string(),
            frame: c.frame,
            until: next.unwrap_or(rec.frames).max(c.frame),
            cut: next.is_some(),
        });
    }
    out
}

impl Asked {
    /// The request's curve: the `hold` frames (at least one) up to and including the last
    /// frame before the command — fewer at the session's start — then every frame the
    /// systems made until the next command or the recording's end. As the benchmark's
    /// reprise answers, which hold `hold` seconds before the TRANSITION.
    pub fn window(&self, hold: usize) -> Window {
        let asked = self.frame;
        Window { first: (asked + 1).saturating_sub(hold.max(1)), asked, end: self.until + 1 }
    }

    /// A system's answer from the labels it showed over the window (`labels[i]`: the label
    /// of the window's frame `i`, a blend's destination; `notes[i]`: what it said about that
    /// frame). Answered when it shows `to` on a frame after the request: the latency is the
    /// frames from the asked frame to the first such frame, as the benchmark counts it.
    /// Otherwise unanswered, saying where the answer ended and the first thing the system
    /// said after the request (a refusal, a failure it recovered from).
    pub fn answer(&self, w: &Window, labels: &[usize], notes: &[Option<&str>], to: usize) -> Answer {
        let at = w.asked_in_curve();
        if let Some(j) = (at + 1..labels.len()).find(|&j| labels[j] == to) {
            return Answer::reached(at, (j - at) as i64);
        }
        let ended = if self.cut { "before the next command" } else { "before the recording ended" };
        let said = notes.iter().skip(at + 1).flatten().next().map(|n| format!("; it said: {n}")).unwrap_or_default();
        Answer { asked: at as i64, ..Answer::failed(format!("never showed `{}` {ended}{said}", self.to)) }
    }
}

#[cfg(test)]
mod tests {
    use reprise_live::command::LiveCommand;
    use reprise_live::session::Stamped;

    use super::*;

    fn recording(frames: usize, commands: &[(usize, &str)]) -> Recording {
        let commands = commands
            .iter()
            .map(|&(frame, text)| Stamped { frame, command: serde_json::from_str::<LiveCommand>(text).unwrap() })
            .collect();
        let json = serde_json::json!({"systems": ["crossfade"], "start": "neutral", "seed": 3, "frames": frames, "commands": []});
        Recording { commands, ..serde_json::from_value(json).unwrap() }
    }

    const TO_ROAR: &str = r#"{"type":"transition","to":"roar"}"#;
    const TO_HAPPY: &str = r#"{"type":"transition","to":"happy"}"#;
    const IDLE: &str = r#"{"type":"idle"}"#;

    /// Each TRANSITION is a request from the label asked before it (the start label for the
    /// first); other commands are not requests but end the answer before them; the last
    /// answer ends with the recording.
    #[test]
    fn transitions_become_requests_from_the_label_asked_before() {
        let rec = recording(100, &[(10, TO_ROAR), (40, IDLE), (50, TO_HAPPY), (70, TO_ROAR)]);
        let got = asked(&rec);
        let want = [
            (0, "neutral", "roar", 10, 40, true),
            (1, "roar", "happy", 50, 70, true),
            (2, "happy", "roar", 70, 100, false),
        ];
        assert_eq!(got.len(), want.len());
        for (a, (request, from, to, frame, until, cut)) in got.iter().zip(want) {
            assert_eq!(
                (a.request, a.from.as_str(), a.to.as_str(), a.frame, a.until, a.cut),
                (request, from, to, frame, until, cut)
            );
        }
        assert!(asked(&recording(100, &[(10, IDLE)])).is_empty(), "no TRANSITION, no request");
    }

    /// The curve holds `hold` frames up to the last frame before the command (index f of
    /// the played sequence), then the frames up to the next command; at the session's start
    /// the hold is shorter, and a command stamped frame 0 is asked at the start frame.
    #[test]
    fn windows_hold_before_the_command_and_end_at_the_next() {
        let rec = recording(100, &[(20, TO_ROAR), (45, TO_HAPPY), (45, IDLE)]);
        let a = asked(&rec);
        let w = a[0].window(12);
        assert_eq!((w.first, w.asked, w.end, w.asked_in_curve(), w.len()), (9, 20, 46, 11, 37));
        // Frames 20..=44 (indices 21..=45) are the answer: 25 frames after the request.
        assert_eq!(w.len() - w.asked_in_curve() - 1, 25);
        let w = a[1].window(12);
        assert_eq!((w.asked_in_curve(), w.len()), (11, 12), "superseded at once: nothing after the request");
        let w = asked(&recording(10, &[(0, TO_ROAR)]))[0].window(12);
        assert_eq!((w.first, w.asked, w.end), (0, 0, 11), "asked at the start frame");
        assert_eq!(asked(&recording(10, &[(5, TO_ROAR)]))[0].window(0).len(), 6, "at least the asked frame");
    }

    /// The latency is the frames from the asked frame to the first frame showing B after
    /// it; B shown before the request does not count; a system that never shows B is
    /// unanswered, saying where its answer ended and what it said.
    #[test]
    fn answers_count_frames_to_the_first_frame_of_b() {
        let rec = recording(30, &[(5, TO_ROAR), (20, IDLE)]);
        let a = &asked(&rec)[0];
        let w = a.window(3);
        assert_eq!((w.first, w.asked, w.end), (3, 5, 21));
        let (a_, b) = (0, 1);
        // Window indices 0..18; asked at 2. B at window index 1 (before) and from 6 on.
        let mut labels = vec![a_; w.len()];
        labels[1] = b;
        labels[6..].iter_mut().for_each(|l| *l = b);
        let quiet = vec![None; w.len()];
        let got = a.answer(&w, &labels, &quiet, b);
        assert_eq!(got, Answer::reached(2, 4));
        let never = vec![a_; w.len()];
        let mut notes = quiet.clone();
        notes[1] = Some("before the request");
        notes[3] = Some("no path to `roar`");
        notes[4] = Some("later");
        let got = a.answer(&w, &never, &notes, b);
        assert_eq!(got.latency, None);
        assert_eq!(got.asked, 2);
        assert_eq!(got.error, "never showed `roar` before the next command; it said: no path to `roar`");
        let last = &asked(&recording(30, &[(5, TO_ROAR)]))[0];
        let w = last.window(3);
        let got = last.answer(&w, &vec![a_; w.len()], &vec![None; w.len()], b);
        assert_eq!(got.error, "never showed `roar` before the recording ended");
    }
}
