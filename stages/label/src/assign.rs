//! Labels and exclusions applied to the frames of every clip, then cut into segments.
//!
//! Precedence, per frame: an exclusion beats everything; an explicit entry (a range or
//! a whole named clip) beats a pattern rule; among rules the first match wins. Two
//! explicit entries may not overlap. Segments are maximal runs of consecutive frames
//! with one label; runs shorter than the minimum length are dropped and counted.

use std::path::Path;

use reprise_artifact::frames::Frames;
use reprise_artifact::segments::Segment;
use reprise_stagekit::{StageError, StageResult};

use crate::labels_file::{Entry, LabelsFile};

/// The outcome of labeling.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Assignment {
    /// Segments, ids in (label order, clip order, start) order.
    pub(crate) segments: Vec<Segment>,
    /// Row indices into the frame table, per segment.
    pub(crate) rows: Vec<Vec<usize>>,
    /// Frames removed by exclusions.
    pub(crate) excluded_frames: usize,
    /// Segments dropped for being shorter than the minimum, and their frames.
    pub(crate) dropped_segments: usize,
    pub(crate) dropped_frames: usize,
    /// Frames no entry labels.
    pub(crate) unlabeled_frames: usize,
}

struct ClipRows<'a> {
    name: &'a str,
    first_row: usize,
    /// Frame numbers of the clip's rows, strictly increasing.
    frames: &'a [i64],
}

impl ClipRows<'_> {
    /// Row offsets within the clip covered by an inclusive range, or an error if the
    /// range runs past the clip's frames.
    fn rows_in(&self, file: &Path, entry: &Entry) -> StageResult<std::ops::Range<usize>> {
        let Some((start, end)) = entry.range else { return Ok(0..self.frames.len()) };
        let (first, last) = (self.frames[0], self.frames[self.frames.len() - 1]);
        if start < first || end > last {
            return Err(StageError::Input(format!(
                "{}: {}: frames {start}..={end} run past clip `{}`, which has frames {first}..={last}",
                file.display(),
                entry.origin,
                self.name
            )));
        }
        Ok(self.frames.partition_point(|&f| f < start)..self.frames.partition_point(|&f| f <= end))
    }
}

/// Applies the labels file to the frames.
pub(crate) fn assign(frames: &Frames, file: &LabelsFile, path: &Path, min_length: usize) -> StageResult<Assignment> {
    let runs = frames.clip_runs();
    let clips: Vec<ClipRows<'_>> =
        runs.iter().map(|(name, a, b)| ClipRows { name, first_row: *a, frames: &frames.frame[*a..*b] }).collect();
    let rows = frames.rows();
    // Per row: the label index and who set it (for overlap messages); exclusion flags.
    let mut explicit: Vec<Option<(usize, &str)>> = vec![None; rows];
    let mut by_rule: Vec<Option<usize>> = vec![None; rows];
    let mut excluded = vec![false; rows];
    let label_index = |l: &String| file.labels.iter().position(|x| x == l).expect("labels come from the entries");
    for entry in &file.entries {
        let targets: Vec<&ClipRows<'_>> = clips.iter().filter(|c| entry.target.matches(c.name)).collect();
        if targets.is_empty() {
            let known: Vec<&str> = clips.iter().take(5).map(|c| c.name).collect();
            return Err(StageError::Input(format!(
                "{}: {}: {} matches no clip (clips include: {}{})",
                path.display(),
                entry.origin,
                entry.target.describe(),
                known.join(", "),
                if clips.len() > 5 { ", …" } else { "" }
            )));
        }
        for clip in targets {
            for row in clip.rows_in(path, entry)?.map(|r| r + clip.first_row) {
                match (&entry.label, entry.is_rule()) {
                    (None, _) => excluded[row] = true,
                    (Some(l), true) => {
                        by_rule[row].get_or_insert(label_index(l));
                    }
                    (Some(l), false) => {
                        if let Some((_, other)) = explicit[row] {
                            return Err(StageError::Input(format!(
                                "{}: {} overlaps {} at clip `{}` frame {}",
                                path.display(),
                                entry.origin,
                                other,
                                clip.name,
                                frames.frame[row]
                            )));
                        }
                        explicit[row] = Some((label_index(l), &entry.origin));
                    }
                }
            }
        }
    }
    let label_of = |r: usize| if excluded[r] { None } else { explicit[r].map(|(l, _)| l).or(by_rule[r]) };
    // Maximal runs of consecutive frames with one label.
    let mut found: Vec<(usize, usize, Vec<usize>)> = Vec::new(); // (label, clip index, rows)
    for (ci, clip) in clips.iter().enumerate() {
        let mut current: Option<(usize, Vec<usize>)> = None;
        for i in 0..clip.frames.len() {
            let row = clip.first_row + i;
            let continues = i > 0 && clip.frames[i] == clip.frames[i - 1] + 1;
            match (label_of(row), current.as_mut()) {
                (Some(l), Some((cl, rs))) if *cl == l && continues => rs.push(row),
                (l, _) => {
                    if let Some((cl, rs)) = current.take() {
                        found.push((cl, ci, rs));
                    }
                    current = l.map(|l| (l, vec![row]));
                }
            }
        }
        if let Some((cl, rs)) = current {
            found.push((cl, ci, rs));
        }
    }
    found.sort_by_key(|(l, c, rs)| (*l, *c, rs[0]));
    let mut out = Assignment {
        segments: Vec::new(),
        rows: Vec::new(),
        excluded_frames: excluded.iter().filter(|x| **x).count(),
        dropped_segments: 0,
        dropped_frames: 0,
        unlabeled_frames: (0..rows).filter(|&r| !excluded[r] && label_of(r).is_none()).count(),
    };
    for (label, ci, seg_rows) in found {
        if seg_rows.len() < min_length {
            out.dropped_segments += 1;
            out.dropped_frames += seg_rows.len();
            continue;
        }
        out.segments.push(Segment {
            segment_id: out.segments.len() as i64,
            label: file.labels[label].clone(),
            clip: clips[ci].name.to_string(),
            start: frames.frame[seg_rows[0]],
            end: frames.frame[seg_rows[seg_rows.len() - 1]],
        });
        out.rows.push(seg_rows);
    }
    if let Some(empty) = file.labels.iter().find(|l| !out.segments.iter().any(|s| &s.label == *l)) {
        return Err(StageError::Input(format!(
            "{}: label `{empty}` has no frames left after exclusions and the minimum segment length of {min_length}",
            path.display()
        )));
    }
    Ok(out)
}
