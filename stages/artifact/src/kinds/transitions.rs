//! `transition_requests` — the transition benchmark: one row per request "from this
//! training frame of label A, reach label B", with how each system answered.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `request` | Int64 | id; the curves of its answers are scripts `r<id>` |
//! | `from`, `to` | Utf8 | labels A and B |
//! | `segment_id`, `clip`, `frame` | Int64, Utf8, Int64 | the start frame (of A) |
//! | `reprise_answered`, `baseline_answered` | Boolean | whether the system reached B |
//! | `reprise_latency`, `baseline_latency` | Int64 | frames from the request to the first frame of B (null if unanswered) |
//! | `reprise_asked`, `baseline_asked` | Int64 | frame of the answer's curves at which the request was made (its first frame of B is `asked + latency`) |
//! | `reprise_error`, `baseline_error` | Utf8 | why not answered (empty if answered) |

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the requests table.
pub const TRANSITION_REQUESTS: Kind = Kind { name: "transition_requests", version: 2 };

/// One system's answer.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Answer {
    /// Frames from the request to the first frame of B, if answered.
    pub latency: Option<i64>,
    /// Index, in the answer's curves, of the frame at which the request was made (a hold
    /// before it is context, not answer).
    pub asked: i64,
    /// Why not answered.
    pub error: String,
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
    /// reprise's answer.
    pub reprise: Answer,
    /// The baseline's answer.
    pub baseline: Answer,
}

/// Writes the requests atomically.
pub fn write(path: &Path, rows: &[Request], provenance: &Provenance) -> Result<()> {
    let s = |f: fn(&Request) -> &str| rows.iter().map(f).collect::<Vec<_>>();
    let cols = Columns::new()
        .i64("request", rows.iter().map(|r| r.request).collect())
        .str("from", &s(|r| r.from.as_str()))
        .str("to", &s(|r| r.to.as_str()))
        .i64("segment_id", rows.iter().map(|r| r.segment_id).collect())
        .str("clip", &s(|r| r.clip.as_str()))
        .i64("frame", rows.iter().map(|r| r.frame).collect())
        .bool("reprise_answered", rows.iter().map(|r| r.reprise.latency.is_some()).collect())
        .bool("baseline_answered", rows.iter().map(|r| r.baseline.latency.is_some()).collect())
        .f64_opt("reprise_latency", rows.iter().map(|r| r.reprise.latency.map(|v| v as f64)).collect())
        .f64_opt("baseline_latency", rows.iter().map(|r| r.baseline.latency.map(|v| v as f64)).collect())
        .i64("reprise_asked", rows.iter().map(|r| r.reprise.asked).collect())
        .i64("baseline_asked", rows.iter().map(|r| r.baseline.asked).collect())
        .str("reprise_error", &s(|r| r.reprise.error.as_str()))
        .str("baseline_error", &s(|r| r.baseline.error.as_str()));
    crate::table::write(path, TRANSITION_REQUESTS, cols, provenance, &[])
}

/// Reads the requests.
pub fn read(path: &Path) -> Result<Vec<Request>> {
    let t = Table::read(path, TRANSITION_REQUESTS)?;
    let (id, from, to, seg, clip, frame) =
        (t.i64("request")?, t.str("from")?, t.str("to")?, t.i64("segment_id")?, t.str("clip")?, t.i64("frame")?);
    let (ra, ba) = (t.i64("reprise_asked")?, t.i64("baseline_asked")?);
    let (rl, bl, re, be) = (
        t.f64_opt("reprise_latency")?,
        t.f64_opt("baseline_latency")?,
        t.str("reprise_error")?,
        t.str("baseline_error")?,
    );
    Ok((0..t.rows())
        .map(|r| Request {
            request: id[r],
            from: from[r].into(),
            to: to[r].into(),
            segment_id: seg[r],
            clip: clip[r].into(),
            frame: frame[r],
            reprise: Answer { latency: rl[r].map(|v| v as i64), asked: ra[r], error: re[r].into() },
            baseline: Answer { latency: bl[r].map(|v| v as i64), asked: ba[r], error: be[r].into() },
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Requests come back as written.
    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let r = Request {
            request: 3,
            from: "a".into(),
            to: "b".into(),
            segment_id: 1,
            clip: "c".into(),
            frame: 9,
            reprise: Answer { latency: Some(30), asked: 12, error: String::new() },
            baseline: Answer { latency: None, asked: 0, error: "start frame pruned".into() },
        };
        let path = dir.path().join("r.parquet");
        write(&path, std::slice::from_ref(&r), &Provenance::new("t", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read(&path).unwrap(), vec![r]);
    }
}
