//! Curve tables in wide form (a column per control) and long form (clip, frame or time,
//! control, value) turned into per-clip curves, then resampled to the pipeline rate.

use std::collections::HashMap;

use reprise_artifact::frames::{Frames, CLIP, FRAME, LABEL, SEGMENT_ID, TIME};
use reprise_stagekit::{StageError, StageResult};

use crate::source::RawTable;

/// Long-form column: control name.
pub(crate) const CONTROL: &str = "control";
/// Long-form column: control value.
pub(crate) const VALUE: &str = "value";

/// One clip's samples at the source's own times.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ClipCurves {
    pub(crate) name: String,
    /// Sample times in seconds, strictly increasing.
    pub(crate) times: Vec<f64>,
    /// Row-major samples × controls.
    pub(crate) values: Vec<f64>,
}

/// Every clip of a source, over one list of controls.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Curves {
    pub(crate) controls: Vec<String>,
    pub(crate) clips: Vec<ClipCurves>,
}

/// How rows map to time.
pub(crate) struct TimeBase<'a> {
    /// Rate of the `frame` column, when times come from frame numbers.
    pub(crate) source_fps: f64,
    /// Clip name for tables without a `clip` column.
    pub(crate) default_clip: &'a str,
    /// A column of times other than `time`/`frame`: seconds, or SMPTE timecodes
    /// `HH:MM:SS:FF[.fff]` whose frame field counts at `source_fps`.
    pub(crate) time_column: Option<&'a str>,
    /// Columns to leave out (e.g. a constant `BlendShapeCount`).
    pub(crate) ignore: &'a [String],
}

impl TimeBase<'_> {
    /// Column names that are not controls.
    fn keys(&self) -> Vec<&str> {
        let mut keys = vec![CLIP, FRAME, TIME];
        keys.extend(self.time_column);
        keys.extend(self.ignore.iter().map(String::as_str));
        keys
    }
}

/// Seconds from `HH:MM:SS:FF[.fff]` (frames at `fps`) or from a plain number.
pub(crate) fn parse_time(cell: &str, fps: f64) -> Option<f64> {
    if let Ok(seconds) = cell.parse::<f64>() {
        return seconds.is_finite().then_some(seconds);
    }
    let parts: Vec<&str> = cell.split(':').collect();
    let [h, m, s, f] = parts.as_slice() else { return None };
    let (h, m, s): (u32, u32, u32) = (h.parse().ok()?, m.parse().ok()?, s.parse().ok()?);
    let f: f64 = f.parse().ok().filter(|f: &f64| f.is_finite() && *f >= 0.0)?;
    (m < 60 && s < 60).then(|| f64::from(h) * 3600.0 + f64::from(m) * 60.0 + f64::from(s) + f / fps)
}

/// Whether a table is in long form (it has `control` and `value` columns).
pub(crate) fn is_long(table: &RawTable) -> bool {
    let names = table.column_names();
    names.iter().any(|n| n == CONTROL) && names.iter().any(|n| n == VALUE)
}

/// Clip name and time of every row.
fn row_keys(table: &RawTable, base: &TimeBase<'_>) -> StageResult<(Vec<String>, Vec<f64>)> {
    let names = table.column_names();
    let has = |c: &str| names.iter().any(|n| n == c);
    let clips = if has(CLIP) { table.strings(CLIP)? } else { vec![base.default_clip.to_string(); table.rows()] };
    let times = if let Some(column) = base.time_column {
        if !has(column) {
            return Err(StageError::Input(format!("{}: no time column `{column}`", table.path().display())));
        }
        let cells = table.strings(column)?;
        let parse = |(row, cell): (usize, &String)| {
            parse_time(cell, base.source_fps).ok_or_else(|| {
                table.error(row, column, &format!("`{cell}` is neither seconds nor a timecode HH:MM:SS:FF[.fff]"))
            })
        };
        cells.iter().enumerate().map(parse).collect::<StageResult<Vec<f64>>>()?
    } else if has(TIME) {
        table.numbers(TIME)?
    } else if has(FRAME) {
        table.integers(FRAME)?.into_iter().map(|f| f as f64 / base.source_fps).collect()
    } else {
        return Err(StageError::Input(format!(
            "{}: no `{FRAME}` or `{TIME}` column; a curve table needs one of them",
            table.path().display()
        )));
    };
    // `-0` and `0` are one time (found by the generative tests: a `-0` beside a `0` made two
    // keys that the long-table grid could not find again).
    Ok((clips, times.into_iter().map(|t| t + 0.0).collect()))
}

/// The column that carries time, for messages.
fn time_column<'a>(table: &RawTable, base: &TimeBase<'a>) -> &'a str {
    if let Some(column) = base.time_column {
        column
    } else if table.column_names().iter().any(|n| n == TIME) {
        TIME
    } else {
        FRAME
    }
}

/// The most controls a curve table may have: 10,000. A hero face rig has a few thousand;
/// each control is a column of every artifact after ingest, and writing one costs about
/// 70 KB of buffers, so 10,000 stay within 1 GB where 100,000 took 6.8 GB.
pub const MAX_CONTROLS: usize = 10_000;

/// Refuses `controls` of the table at `path` when there are more than [`MAX_CONTROLS`], or
/// when two names differ only in case (`Jaw`, `jaw`): rigs, file systems and DCC tools
/// disagree on whether those are one control, so a table must not depend on it.
pub(crate) fn check_controls(path: &std::path::Path, controls: &[String]) -> StageResult<()> {
    if controls.len() > MAX_CONTROLS {
        return Err(StageError::Input(format!(
            "{}: {} controls, more than the {MAX_CONTROLS} reprise reads (a rig has a few thousand at most); is a \
             long table (`clip`, `time`, `control`, `value`) being read as a wide one, or are unrelated columns \
             included? (--ignore-columns drops columns)",
            path.display(),
            controls.len()
        )));
    }
    let mut seen: HashMap<String, &str> = HashMap::with_capacity(controls.len());
    for c in controls {
        if let Some(first) = seen.insert(c.to_lowercase(), c) {
            return Err(StageError::Input(format!(
                "{}: controls `{first}` and `{c}` differ only in case; rename one (rigs and tools disagree on \
                 whether they are the same control)",
                path.display()
            )));
        }
    }
    Ok(())
}

/// Reads a wide table: `clip`? , `frame` and/or `time`, then one numeric column per control.
pub(crate) fn wide(table: &RawTable, base: &TimeBase<'_>) -> StageResult<Curves> {
    let names = table.column_names();
    if let Some(reserved) = names.iter().find(|n| [LABEL, SEGMENT_ID].contains(&n.as_str())) {
        return Err(StageError::Input(format!(
            "{}: column `{reserved}` is reserved for labeled frames and cannot be a control",
            table.path().display()
        )));
    }
    let keys = base.keys();
    let controls: Vec<String> = names.iter().filter(|n| !keys.contains(&n.as_str())).cloned().collect();
    if controls.is_empty() {
        return Err(StageError::Input(format!("{}: no control columns", table.path().display())));
    }
    check_controls(table.path(), &controls)?;
    let (clips, times) = row_keys(table, base)?;
    let columns = controls.iter().map(|c| table.numbers(c)).collect::<StageResult<Vec<_>>>()?;
    let mut order: Vec<String> = Vec::new();
    let mut rows_of: HashMap<&str, Vec<usize>> = HashMap::new();
    for (row, clip) in clips.iter().enumerate() {
        let rows = rows_of.entry(clip).or_default();
        if rows.is_empty() {
            order.push(clip.clone());
        }
        if let Some(&prev) = rows.last() {
            let what = time_column(table, base);
            if times[row] == times[prev] {
                return Err(table.error(row, what, &format!("clip `{clip}`: {what} repeats {}", table.at(prev))));
            }
            if times[row] < times[prev] {
                return Err(table.error(
                    row,
                    what,
                    &format!("clip `{clip}`: {what} goes back from {}", table.at(prev)),
                ));
            }
        }
        rows.push(row);
    }
    let clips = order
        .into_iter()
        .map(|name| {
            let rows = &rows_of[name.as_str()];
            let values = rows.iter().flat_map(|&r| columns.iter().map(move |col| col[r])).collect();
            ClipCurves { times: rows.iter().map(|&r| times[r]).collect(), values, name }
        })
        .collect();
    Ok(Curves { controls, clips })
}

/// Reads a long table: `clip`?, `frame` or `time`, `control`, `value`. Every control
/// must have a value at every time of its clip, exactly once.
pub(crate) fn long(table: &RawTable, base: &TimeBase<'_>) -> StageResult<Curves> {
    let names = table.column_names();
    let mut known = base.keys();
    known.extend([CONTROL, VALUE]);
    if let Some(unknown) = names.iter().find(|n| !known.contains(&n.as_str())) {
        return Err(StageError::Input(format!(
            "{}: unknown column `{unknown}`; a long table has the columns clip (optional), frame or time, control, value",
            table.path().display()
        )));
    }
    let (clips, times) = row_keys(table, base)?;
    let control_of_row = table.strings(CONTROL)?;
    let value = table.numbers(VALUE)?;
    let mut controls: Vec<String> = Vec::new();
    let mut control_index: HashMap<&str, usize> = HashMap::new();
    for c in &control_of_row {
        if !control_index.contains_key(c.as_str()) {
            control_index.insert(c, controls.len());
            controls.push(c.clone());
        }
    }
    check_controls(table.path(), &controls)?;
    // Per clip, in first-appearance order: the sorted distinct times, then a filled grid.
    let mut order: Vec<&str> = Vec::new();
    let mut rows_of: HashMap<&str, Vec<usize>> = HashMap::new();
    for (row, clip) in clips.iter().enumerate() {
        rows_of.entry(clip).or_insert_with(|| {
            order.push(clip);
            Vec::new()
        });
        rows_of.get_mut(clip.as_str()).expect("inserted above").push(row);
    }
    let n = controls.len();
    let mut out = Vec::new();
    for name in order {
        let rows = &rows_of[name];
        let mut distinct: Vec<f64> = rows.iter().map(|&r| times[r]).collect();
        distinct.sort_by(f64::total_cmp);
        distinct.dedup();
        let mut cell: Vec<Option<usize>> = vec![None; distinct.len() * n];
        for &row in rows {
            let t = distinct.binary_search_by(|x| x.total_cmp(&times[row])).expect("time is among the distinct times");
            let slot = &mut cell[t * n + control_index[control_of_row[row].as_str()]];
            if let Some(first) = *slot {
                return Err(table.error(
                    row,
                    CONTROL,
                    &format!(
                        "clip `{name}`: control `{}` at time {} s repeats {}",
                        control_of_row[row],
                        times[row],
                        table.at(first)
                    ),
                ));
            }
            *slot = Some(row);
        }
        if let Some(missing) = cell.iter().position(Option::is_none) {
            let (t, c) = (missing / n, missing % n);
            return Err(StageError::Input(format!(
                "{}: clip `{name}`, time {} s: control `{}` is missing (other controls have a value there)",
                table.path().display(),
                distinct[t],
                controls[c]
            )));
        }
        let values = cell.into_iter().map(|r| value[r.expect("checked above")]).collect();
        out.push(ClipCurves { name: name.to_string(), times: distinct, values });
    }
    Ok(Curves { controls, clips: out })
}

/// The sampling rate a clip was given at: the median of `1/Δt`, or `fallback` for a
/// single sample.
pub(crate) fn source_rate(times: &[f64], fallback: f64) -> f64 {
    let mut rates: Vec<f64> = times.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();
    if rates.is_empty() {
        return fallback;
    }
    rates.sort_by(f64::total_cmp);
    rates[rates.len() / 2]
}

/// Refuses, before anything is allocated, a resampling to `fps` that would make more than
/// `max_frames` frames or `max_values` values (frames × controls), naming the clip and the
/// row (and column) of its latest time.
pub(crate) fn check_budget(
    table: &RawTable,
    base: &TimeBase<'_>,
    curves: &Curves,
    fps: f64,
    (max_frames, max_values): (usize, usize),
) -> StageResult<()> {
    let frames = |c: &ClipCurves| (c.times[c.times.len() - 1] - c.times[0]) * fps + 1.0;
    let total: f64 = curves.clips.iter().map(frames).sum();
    let values = total * curves.controls.len() as f64;
    if total <= max_frames as f64 && values <= max_values as f64 {
        return Ok(());
    }
    let Some(clip) = curves.clips.iter().max_by(|a, b| frames(a).total_cmp(&frames(b))) else { return Ok(()) };
    let (clips, times) = row_keys(table, base)?;
    let row = (0..times.len()).filter(|&r| clips[r] == clip.name).max_by(|&a, &b| times[a].total_cmp(&times[b]));
    let limit = if total > max_frames as f64 {
        format!("more than the limit --max-frames {max_frames}")
    } else {
        format!(
            "which with {} controls is {values:.0} values, more than the limit --max-values {max_values}",
            curves.controls.len()
        )
    };
    let message = format!(
        "clip `{}` runs from {} s to {} s, which at {fps} fps makes {:.0} frames ({total:.0} in all clips), {limit}; \
         is this time a typo? (raise the limit if it is not)",
        clip.name,
        clip.times[0],
        clip.times[clip.times.len() - 1],
        frames(clip)
    );
    Err(match row {
        Some(row) => table.error(row, time_column(table, base), &message),
        None => StageError::Input(format!("{}: {message}", table.path().display())),
    })
}

/// Resamples every clip onto `t_k = t_0 + k / fps`, `k = 0 … ⌊(t_end − t_0)·fps⌋`, by
/// linear interpolation between the bracketing samples (exact copies where the source
/// already lies on the grid), and restarts time at 0 for each clip.
pub(crate) fn resample(curves: &Curves, fps: f64) -> Frames {
    let n = curves.controls.len();
    let mut frames = Frames {
        fps,
        controls: curves.controls.clone(),
        clip: Vec::new(),
        frame: Vec::new(),
        time: Vec::new(),
        values: Vec::new(),
    };
    for clip in &curves.clips {
        let t0 = clip.times[0];
        let span = clip.times[clip.times.len() - 1] - t0;
        let count = (span * fps + 1e-6).floor() as usize + 1;
        let mut j = 0;
        for k in 0..count {
            let t = t0 + k as f64 / fps;
            while j + 1 < clip.times.len() && clip.times[j + 1] <= t + 1e-9 {
                j += 1;
            }
            let row = |i: usize| &clip.values[i * n..(i + 1) * n];
            if j + 1 == clip.times.len() || (clip.times[j] - t).abs() <= 1e-9 {
                frames.values.extend_from_slice(row(j));
            } else {
                let a = (t - clip.times[j]) / (clip.times[j + 1] - clip.times[j]);
                frames.values.extend(row(j).iter().zip(row(j + 1)).map(|(x, y)| x + a * (y - x)));
            }
            frames.clip.push(clip.name.clone());
            frames.frame.push(k as i64);
            frames.time.push(k as f64 / fps);
        }
    }
    frames
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timecodes_and_seconds() {
        assert_eq!(parse_time("1.25", 60.0), Some(1.25));
        let t = parse_time("00:32:09:08.868", 60.0).unwrap();
        assert!((t - (32.0 * 60.0 + 9.0 + 8.868 / 60.0)).abs() < 1e-12);
        assert_eq!(parse_time("01:00:00:30", 30.0), Some(3601.0));
        for bad in ["", "12:00", "00:61:00:00", "a:b:c:d", "00:00:00:-1", "nan"] {
            assert_eq!(parse_time(bad, 30.0), None, "{bad}");
        }
    }

    fn clip(times: Vec<f64>, values: Vec<f64>) -> Curves {
        Curves { controls: vec!["a".into()], clips: vec![ClipCurves { name: "c".into(), times, values }] }
    }

    /// Samples on the target grid come through unchanged.
    #[test]
    fn resampling_on_the_grid_is_identity() {
        let c = clip(vec![0.0, 0.5, 1.0], vec![1.0, 2.0, 4.0]);
        let f = resample(&c, 2.0);
        assert_eq!(f.values, vec![1.0, 2.0, 4.0]);
        assert_eq!(f.frame, vec![0, 1, 2]);
    }

    /// 60 fps samples of a linear ramp resampled to 24 fps stay on the ramp.
    #[test]
    fn resampling_interpolates_linearly() {
        let times: Vec<f64> = (0..=60).map(|i| f64::from(i) / 60.0).collect();
        let values = times.iter().map(|t| 3.0 * t + 1.0).collect();
        let f = resample(&clip(times, values), 24.0);
        assert_eq!(f.rows(), 25);
        for (t, v) in f.time.iter().zip(&f.values) {
            assert!((v - (3.0 * t + 1.0)).abs() < 1e-12, "{t} {v}");
        }
        assert!((source_rate(&[0.0, 1.0 / 60.0, 2.0 / 60.0], 24.0) - 60.0).abs() < 1e-9);
    }

    /// A gap in the frames is filled by interpolation; time restarts at zero.
    #[test]
    fn resampling_fills_gaps_and_restarts_time() {
        let f = resample(&clip(vec![10.0, 10.75], vec![0.0, 3.0]), 4.0);
        assert_eq!(f.values, vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(f.time, vec![0.0, 0.25, 0.5, 0.75]);
    }
}
