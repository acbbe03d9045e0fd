//! A curve table onto a blendshape face: each column names a shape (any case, as Live
//! Link Face's `EyeBlinkLeft` names ARKit's `eyeBlinkLeft`), the controls are the face's
//! shapes in its order, and shapes the table lacks hold 0.

use std::path::Path;

use reprise_artifact::controls::{Control, Controls, RigRef};
use reprise_artifact::frames::Frames;
use reprise_blendshape::Blendshapes;
use reprise_stagekit::{StageError, StageResult};

/// `frames` with one column per shape of the face at `face` (hash `blake3`), and its
/// controls table.
///
/// # Errors
/// The face cannot be read; a column names no shape (listed, with how to leave it out:
/// `--ignore-columns`); two columns name one shape.
pub(crate) fn onto_shapes(
    frames: Frames,
    face: &Path,
    blake3: String,
    ignored: &[String],
) -> StageResult<(Frames, Controls)> {
    let shapes = Blendshapes::read_zip(face).map_err(|e| StageError::Input(e.to_string()))?;
    let column_of = |shape: &str| -> Vec<usize> {
        let exact: Vec<usize> =
            frames.controls.iter().enumerate().filter(|(_, c)| *c == shape).map(|(i, _)| i).collect();
        if exact.is_empty() {
            frames.controls.iter().enumerate().filter(|(_, c)| c.eq_ignore_ascii_case(shape)).map(|(i, _)| i).collect()
        } else {
            exact
        }
    };
    let mut source: Vec<Option<usize>> = Vec::with_capacity(shapes.names.len());
    let mut used = vec![false; frames.controls.len()];
    for shape in &shapes.names {
        let columns = column_of(shape);
        if columns.len() > 1 {
            let names: Vec<&str> = columns.iter().map(|&c| frames.controls[c].as_str()).collect();
            return Err(StageError::Input(format!(
                "columns {} all name the shape `{shape}` of {}; keep one (--ignore-columns the others)",
                names.join(", "),
                face.display()
            )));
        }
        if let Some(&c) = columns.first() {
            used[c] = true;
        }
        source.push(columns.first().copied());
    }
    let unmatched: Vec<&str> =
        frames.controls.iter().zip(&used).filter(|(_, u)| !**u).map(|(c, _)| c.as_str()).collect();
    if !unmatched.is_empty() {
        return Err(StageError::Input(format!(
            "{} columns name no shape of {} ({} shapes, e.g. `{}`): {}; leave them out with --ignore-columns{}",
            unmatched.len(),
            face.display(),
            shapes.names.len(),
            shapes.names[0],
            unmatched.join(", "),
            if ignored.is_empty() { String::new() } else { format!(" (it already leaves out {})", ignored.join(", ")) }
        )));
    }
    let n = frames.controls.len();
    let old = &frames.values;
    let values: Vec<f64> =
        (0..frames.rows()).flat_map(|r| source.iter().map(move |s| s.map_or(0.0, |c| old[r * n + c]))).collect();
    let out = Frames { controls: shapes.names.clone(), values, ..frames };
    let controls = (0..out.controls.len())
        .map(|c| {
            let column = out.column(c);
            let (min, max) = column.iter().fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
            Control {
                name: out.controls[c].clone(),
                group: "shapes".into(),
                unit: "weight".into(),
                default: 0.0,
                min,
                max,
                animated: crate::dragon::moves(&out, c),
            }
        })
        .collect();
    let rig = RigRef::Blendshapes { path: face.display().to_string(), blake3 };
    Ok((out, Controls { controls, rig }))
}
