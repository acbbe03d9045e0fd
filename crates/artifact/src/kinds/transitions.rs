//! The transition benchmark's two artifact kinds.
//!
//! `transition_requests` — one row per request "from this training frame of label A,
//! reach label B", drawn once (seeded) and answered by every system alike:
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `request` | Int64 | id; the curves of its answers are scripts `r<id>` |
//! | `from`, `to` | Utf8 | labels A and B |
//! | `segment_id`, `clip`, `frame` | Int64, Utf8, Int64 | the start frame (of A) |
//!
//! `transition_answers` — one system's answers, one row per request:
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `system` | Utf8 | who answered (`reprise`, `motion-graphs`, `motion-matching`, `crossfade`) |
//! | `request` | Int64 | the request's id |
//! | `answered` | Boolean | whether the system reached B |
//! | `asked` | Int64 | frame of the answer's curves at which the request was made (a hold before it is context, not answer) |
//! | `latency` | Float64 (null if unanswered) | frames from `asked` to the first frame of B |
//! | `error` | Utf8 | why not answered (empty if answered) |

use std::collections::HashMap;
use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the requests table.
pub const TRANSITION_REQUESTS: Kind = Kind { name: "transition_requests", version: 3 };
/// Kind of one system's answers.
pub const TRANSITION_ANSWERS: Kind = Kind { name: "transition_answers", version: 2 };

/// One system's answer to one request.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Answer {
    /// Frames from the request to the first frame of B, if answered.
    pub latency: Option<i64>,
    /// Index, in the answer's curves, of the frame at which the request was made.
    pub asked: i64,
    /// Why not answered.
    pub error: String,
}

impl Answer {
    /// An answer whose first frame of B is `latency` frames after frame `asked`.
    pub fn reached(asked: usize, latency: i64) -> Self {
        Self { latency: Some(latency), asked: asked as i64, error: String::new() }
    }

    /// A refusal, with the reason.
    pub fn failed(error: impl Into<String>) -> Self {
        Self { latency: None, asked: 0, error: error.into() }
    }
}

/// One request.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    /// Id.
    pub request: i64,
    /// Label A.
    pub from: String,
    /// Label B.
    pub to: String,
    /// Start segment.
    pub segment_id: i64,
    /// Start clip.
    pub clip: String,
    /// Start frame.
    pub frame: i64,
}

/// One system's answers, by request id.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Answers {
    /// Who answered.
    pub system: String,
    /// Its answer to each request it was asked.
    pub by_request: HashMap<i64, Answer>,
}

impl Answers {
    /// The answer to `request`, if the system was asked it.
    pub fn get(&self, request: i64) -> Option<&Answer> {
        self.by_request.get(&request)
    }
}

/// Writes the requests atomically.
pub fn write_requests(path: &Path, rows: &[Request], provenance: &Provenance) -> Result<()> {
    let s = |f: fn(&Request) -> &str| rows.iter().map(f).collect::<Vec<_>>();
    let cols = Columns::new()
        .i64("request", rows.iter().map(|r| r.request).collect())
        .str("from", &s(|r| r.from.as_str()))
        .str("to", &s(|r| r.to.as_str()))
        .i64("segment_id", rows.iter().map(|r| r.segment_id).collect())
        .str("clip", &s(|r| r.clip.as_str()))
        .i64("frame", rows.iter().map(|r| r.frame).collect());
    crate::table::write(path, TRANSITION_REQUESTS, cols, provenance, &[])
}

/// Reads the requests; ids must be unique.
pub fn read_requests(path: &Path) -> Result<Vec<Request>> {
    let t = Table::read(path, TRANSITION_REQUESTS)?;
    let (id, from, to, seg, clip, frame) =
        (t.i64("request")?, t.str("from")?, t.str("to")?, t.i64("segment_id")?, t.str("clip")?, t.i64("frame")?);
    let mut seen = std::collections::HashSet::new();
    if let Some(r) = (0..t.rows()).find(|&r| !seen.insert(id[r])) {
        return Err(t.invalid(format!("row {r}: request id {} appears twice", id[r])));
    }
    Ok((0..t.rows())
        .map(|r| Request {
            request: id[r],
            from: from[r].into(),
            to: to[r].into(),
            segment_id: seg[r],
            clip: clip[r].into(),
            frame: frame[r],
        })
        .collect())
}

/// Writes one system's answers (`answers` in request order) atomically.
pub fn write_answers(path: &Path, system: &str, answers: &[(i64, Answer)], provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .str("system", &vec![system; answers.len()])
        .i64("request", answers.iter().map(|(r, _)| *r).collect())
        .bool("answered", answers.iter().map(|(_, a)| a.latency.is_some()).collect())
        .i64("asked", answers.iter().map(|(_, a)| a.asked).collect())
        .f64_opt("latency", answers.iter().map(|(_, a)| a.latency.map(|v| v as f64)).collect())
        .str("error", &answers.iter().map(|(_, a)| a.error.as_str()).collect::<Vec<_>>());
    crate::table::write(path, TRANSITION_ANSWERS, cols, provenance, &[])
}

/// Reads one system's answers: one system per file, request ids unique, latencies
/// non-negative whole frames.
pub fn read_answers(path: &Path) -> Result<Answers> {
    let t = Table::read(path, TRANSITION_ANSWERS)?;
    let (system, id, asked, latency, error) =
        (t.str("system")?, t.i64("request")?, t.i64("asked")?, t.f64_opt("latency")?, t.str("error")?);
    let mut out = Answers { system: system.first().map_or(String::new(), |s| s.to_string()), ..Default::default() };
    for r in 0..t.rows() {
        if system[r] != out.system {
            return Err(t.invalid(format!("row {r}: system `{}` in a file of `{}`'s answers", system[r], out.system)));
        }
        let latency = match latency[r] {
            Some(l) if l < 0.0 || l.fract() != 0.0 || l > 1e9 => {
                return Err(t.invalid(format!("row {r}: latency {l} is not a whole number of frames ≥ 0")))
            }
            l => l.map(|l| l as i64),
        };
        if asked[r] < 0 {
            return Err(t.invalid(format!("row {r}: asked {} < 0", asked[r])));
        }
        let a = Answer { latency, asked: asked[r], error: error[r].into() };
        if out.by_request.insert(id[r], a).is_some() {
            return Err(t.invalid(format!("row {r}: request {} answered twice", id[r])));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn provenance() -> Provenance {
        Provenance::new("t", "0", serde_json::json!({}))
    }

    /// Requests and answers come back as written.
    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let r = Request { request: 3, from: "a".into(), to: "b".into(), segment_id: 1, clip: "c".into(), frame: 9 };
        let path = dir.path().join("r.parquet");
        write_requests(&path, std::slice::from_ref(&r), &provenance()).unwrap();
        assert_eq!(read_requests(&path).unwrap(), vec![r]);
        let answers = vec![(3, Answer::reached(12, 30)), (4, Answer::failed("start frame pruned"))];
        let path = dir.path().join("a.parquet");
        write_answers(&path, "motion-graphs", &answers, &provenance()).unwrap();
        let back = read_answers(&path).unwrap();
        assert_eq!(back.system, "motion-graphs");
        assert_eq!(back.get(3), Some(&answers[0].1));
        assert_eq!(back.get(4), Some(&answers[1].1));
        assert_eq!(back.get(5), None);
    }

    /// A request answered twice is refused, naming the row.
    #[test]
    fn duplicate_answers_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.parquet");
        write_answers(&path, "x", &[(1, Answer::reached(0, 3)), (1, Answer::reached(0, 4))], &provenance()).unwrap();
        let e = read_answers(&path).unwrap_err().to_string();
        assert!(e.contains("row 1") && e.contains("answered twice"), "{e}");
    }
}
