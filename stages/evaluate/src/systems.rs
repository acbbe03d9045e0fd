//! The systems compared on the transition benchmark, and what each of them played.

use std::collections::BTreeMap;
use std::path::Path;

use reprise_artifact::curves::{self, Curves};
use reprise_artifact::transitions::{self, Answer, Answers, Request};
use reprise_stagekit::{StageError, StageResult};

/// One answer's frames: controls (rows in the labeled frames' control order) and, per
/// frame, the label that produced it (a blended frame counts as the label blended into)
/// and, for a system with latent spaces, the latent point.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Played {
    /// Controls per frame.
    pub controls: Vec<Vec<f64>>,
    /// Producing label per frame.
    pub model: Vec<String>,
    /// Latent point per frame (empty vectors, or no entries: the system has none).
    pub x: Vec<Vec<f64>>,
}

/// One system: its answers and the frames it played for each answered request.
#[derive(Debug, Clone)]
pub struct System {
    /// Id (see [`reprise_benchmark::systems::SYSTEMS`]).
    pub id: String,
    /// Name shown in the report.
    pub shown: String,
    /// Its answers, one per request.
    pub answers: Answers,
    /// Frames per request id.
    pub played: BTreeMap<i64, Played>,
    /// The curves of the same requests answered under other seeds, where the system has
    /// seeds: read only by [`Self::reseeded`], for the variety measure, and dropped after
    /// it (they are as large as the curves themselves).
    pub reseeded_curves: Option<std::path::PathBuf>,
}

impl System {
    /// The answer to `r` (every request of the benchmark has one: checked on load).
    pub fn answer(&self, r: &Request) -> Option<&Answer> {
        self.answers.get(r.request)
    }

    /// Whether `r` was answered.
    pub fn answered(&self, r: &Request) -> bool {
        self.answer(r).is_some_and(|a| a.latency.is_some())
    }

    /// Loads a system's answers and curves and checks them against the requests and the
    /// controls: the file says it is `id`'s, answers every request once, and the frames of
    /// every answered request reach as far as its latency says.
    pub fn load(
        id: &str,
        answers: &Path,
        curves_path: &Path,
        reseeded: Option<&Path>,
        requests: &[Request],
        controls: &[String],
    ) -> StageResult<Self> {
        let shown = reprise_benchmark::systems::shown(id).to_string();
        let a = transitions::read_answers(answers)?;
        if a.system != id && !(a.by_request.is_empty() && requests.is_empty()) {
            return Err(StageError::Input(format!(
                "{} holds `{}`'s answers where `{id}`'s were expected",
                answers.display(),
                a.system
            )));
        }
        if let Some(r) = requests.iter().find(|r| a.get(r.request).is_none()) {
            return Err(StageError::Input(format!(
                "{} has no answer to request {}; it answers another benchmark (rerun the stage that wrote it)",
                answers.display(),
                r.request
            )));
        }
        let played = read_played(curves_path, controls)?;
        for r in requests {
            let ans = a.get(r.request).expect("checked above");
            if let Some(l) = ans.latency {
                let len = played.get(&r.request).map_or(0, |p| p.controls.len()) as i64;
                if ans.asked + l >= len {
                    return Err(StageError::Input(format!(
                        "{}: request {} is answered at frame {} but {} holds {len} frames of it",
                        answers.display(),
                        r.request,
                        ans.asked + l,
                        curves_path.display()
                    )));
                }
            }
        }
        Ok(Self { id: id.into(), shown, answers: a, played, reseeded_curves: reseeded.map(Path::to_path_buf) })
    }

    /// The frames played under the other seeds, per request (`None`: the system has no
    /// seeds), checked against `controls` as the curves are.
    pub fn reseeded(&self, controls: &[String]) -> StageResult<Option<BTreeMap<i64, Played>>> {
        self.reseeded_curves.as_deref().map(|p| read_played(p, controls)).transpose()
    }
}

/// A curves file's frames per request, after checking that it lists `controls`.
fn read_played(p: &Path, controls: &[String]) -> StageResult<BTreeMap<i64, Played>> {
    let c = curves::read(p)?;
    if c.controls != controls {
        return Err(StageError::Input(format!("{} lists other controls than the labeled frames", p.display())));
    }
    // A non-finite control would measure as a perfect score (every comparison with NaN is
    // false): refused, naming the row and the control.
    let n = controls.len().max(1);
    if let Some(i) = c.values.iter().position(|v| !v.is_finite()) {
        return Err(StageError::Input(format!(
            "{}: row {} (script `{}`, frame {}), control `{}` is {}; rerun the stage that wrote it",
            p.display(),
            i / n,
            c.script.get(i / n).map_or("", String::as_str),
            c.frame.get(i / n).copied().unwrap_or(-1),
            controls.get(i % n).map_or("", String::as_str),
            c.values[i]
        )));
    }
    Ok(by_request(&c))
}

/// Frames per request: scripts are named `r<id>`; other scripts are ignored.
pub fn by_request(c: &Curves) -> BTreeMap<i64, Played> {
    let n = c.controls.len();
    let mut out: BTreeMap<i64, Played> = BTreeMap::new();
    for r in 0..c.script.len() {
        let Some(id) = c.script[r].strip_prefix('r').and_then(|s| s.parse().ok()) else { continue };
        let p = out.entry(id).or_default();
        p.controls.push(c.values[r * n..(r + 1) * n].to_vec());
        p.model.push(c.model[r].clone());
        p.x.push(c.x[r].clone());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curves file with a non-finite control is refused, naming the file (it would
    /// otherwise measure as a perfect score); the same file without it loads.
    #[test]
    fn non_finite_curves_are_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("reprise-nan-curves-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let controls = vec!["jaw".to_string(), "brow".to_string()];
        let mut c = Curves { fps: 24.0, controls: controls.clone(), ..Default::default() };
        let frames = [[0.0, 0.1], [0.2, f64::NAN]];
        c.push_script("r7", frames.iter().map(|p| curves::Frame::plain("a", p)));
        let provenance = reprise_artifact::Provenance::new("t", "0", serde_json::json!({}));
        let path = dir.join("curves.parquet");
        let refused = curves::write(&path, &c, &provenance)
            .err()
            .map(|e| e.to_string())
            .or_else(|| read_played(&path, &controls).err().map(|e| e.to_string()));
        let e = refused.expect("a NaN control must not load");
        assert!(e.contains("curves.parquet") && (e.contains("NaN") || e.contains("finite")), "{e}");
        c.values[3] = 0.3;
        curves::write(&path, &c, &provenance).unwrap();
        assert_eq!(read_played(&path, &controls).unwrap()[&7].controls[1], vec![0.2, 0.3]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
