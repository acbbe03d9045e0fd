//! The systems compared on the transition benchmark, and what each of them played.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use reprise_artifact::curves;
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

/// The requests a system did not answer, and why (its own words: each system's answers
/// carry the reason it gave).
#[derive(Debug, Clone, PartialEq)]
pub struct Refusals {
    /// The system's shown name.
    pub system: String,
    /// Requests not answered.
    pub refused: usize,
    /// Requests asked.
    pub asked: usize,
    /// (reason, requests), most frequent first.
    pub reasons: Vec<(String, usize)>,
}

/// One system: its answers, and where the frames it played are. The frames are streamed
/// request by request ([`System::stream`]) — a benchmark's curves do not fit in memory —
/// except those of the requests the player shows ([`System::keep_played`]).
#[derive(Debug, Clone)]
pub struct System {
    /// Id (see [`reprise_benchmark::systems::SYSTEMS`]).
    pub id: String,
    /// Name shown in the report.
    pub shown: String,
    /// Its answers, one per request.
    pub answers: Answers,
    /// Frames of the requests kept by [`System::keep_played`], per request id.
    pub played: BTreeMap<i64, Played>,
    /// The file its answers came from.
    pub answers_file: PathBuf,
    /// Its curves: one script `r<id>` per request it played, in request order.
    pub curves: PathBuf,
    /// The curves of the same requests answered under other seeds, where the system has
    /// seeds (for the variety measure).
    pub reseeded_curves: Option<PathBuf>,
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

    /// Loads a system's answers and checks them against the requests: the file says it is
    /// `id`'s and answers every request once. Its curves are checked as they are streamed.
    pub fn load(
        id: &str,
        answers: &Path,
        curves: &Path,
        reseeded: Option<&Path>,
        requests: &[Request],
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
        Ok(Self {
            id: id.into(),
            shown,
            answers: a,
            played: BTreeMap::new(),
            answers_file: answers.into(),
            curves: curves.into(),
            reseeded_curves: reseeded.map(Path::to_path_buf),
        })
    }

    /// The requests of `requests` the system did not answer, grouped by the reason it gave
    /// (most frequent first, then by reason).
    pub fn refusals(&self, requests: &[Request]) -> Refusals {
        let mut by_reason: BTreeMap<&str, usize> = BTreeMap::new();
        let mut refused = 0;
        for r in requests.iter().filter(|r| !self.answered(r)) {
            refused += 1;
            let why = self.answer(r).map_or("", |a| a.error.as_str());
            *by_reason.entry(if why.is_empty() { "no reason given" } else { why }).or_default() += 1;
        }
        let mut reasons: Vec<(String, usize)> = by_reason.into_iter().map(|(w, n)| (w.to_string(), n)).collect();
        reasons.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        Refusals { system: self.shown.clone(), refused, asked: requests.len(), reasons }
    }

    /// The system's frames, request by request in file order.
    pub fn stream(&self, controls: &[String]) -> StageResult<PlayedStream> {
        PlayedStream::open(&self.curves, controls)
    }

    /// The frames played under the other seeds (`None`: the system has no seeds).
    pub fn stream_reseeded(&self, controls: &[String]) -> StageResult<Option<PlayedStream>> {
        self.reseeded_curves.as_deref().map(|p| PlayedStream::open(p, controls)).transpose()
    }

    /// Reads the frames of the requests `ids` into [`System::played`].
    pub fn keep_played(&mut self, ids: &HashSet<i64>, controls: &[String]) -> StageResult<()> {
        self.played.clear();
        for item in self.stream(controls)? {
            let (id, p) = item?;
            if ids.contains(&id) {
                self.played.insert(id, p);
            }
        }
        Ok(())
    }

    /// Checks that the `len` frames played for `r` reach as far as its answer says.
    pub fn check_reach(&self, r: &Request, len: usize) -> StageResult<()> {
        let Some(ans) = self.answer(r) else { return Ok(()) };
        match ans.latency {
            Some(l) if ans.asked + l >= len as i64 => Err(StageError::Input(format!(
                "{}: request {} is answered at frame {} but {} holds {len} frames of it",
                self.answers_file.display(),
                r.request,
                ans.asked + l,
                self.curves.display()
            ))),
            _ => Ok(()),
        }
    }

    /// A system given in memory (`id`, its answers and its frames; no files), as tests
    /// and synthetic systems build one.
    pub fn in_memory(id: &str, answers: Answers, played: BTreeMap<i64, Played>) -> Self {
        Self {
            id: id.into(),
            shown: id.into(),
            answers,
            played,
            answers_file: PathBuf::new(),
            curves: PathBuf::new(),
            reseeded_curves: None,
        }
    }
}

/// A curves file's frames per request, one request at a time, in file order: scripts are
/// named `r<id>` (other scripts are skipped) and come in increasing request order, as the
/// benchmark's stages write them; anything else is an error naming the file.
pub struct PlayedStream {
    scripts: curves::Scripts,
    path: PathBuf,
    /// File rows before the current script (for error messages).
    row: usize,
    last: Option<i64>,
}

impl PlayedStream {
    /// Opens `path`, checking that it lists `controls`.
    pub fn open(path: &Path, controls: &[String]) -> StageResult<Self> {
        let scripts = curves::Scripts::open(path)?;
        if scripts.controls != controls {
            return Err(StageError::Input(format!("{} lists other controls than the labeled frames", path.display())));
        }
        Ok(Self { scripts, path: path.into(), row: 0, last: None })
    }

    fn next_played(&mut self) -> StageResult<Option<(i64, Played)>> {
        loop {
            let Some(script) = self.scripts.next().transpose()? else { return Ok(None) };
            let first_row = self.row;
            self.row += script.frame.len();
            let Some(id) = script.name.strip_prefix('r').and_then(|s| s.parse::<i64>().ok()) else { continue };
            if self.last.is_some_and(|last| id <= last) {
                return Err(StageError::Input(format!(
                    "{}: script `{}` (row {first_row}) comes after request {}: the scripts must be one per \
                     request, in request order; rerun the stage that wrote it",
                    self.path.display(),
                    script.name,
                    self.last.unwrap_or_default()
                )));
            }
            self.last = Some(id);
            return played(&self.path, &self.scripts.controls, script, first_row).map(|p| Some((id, p)));
        }
    }
}

impl Iterator for PlayedStream {
    type Item = StageResult<(i64, Played)>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_played().transpose()
    }
}

/// One script's frames. A non-finite control would measure as a perfect score (every
/// comparison with NaN is false): refused, naming the row and the control.
fn played(path: &Path, controls: &[String], s: curves::Script, first_row: usize) -> StageResult<Played> {
    let frames = s.frame.len();
    let n = s.values.len().checked_div(frames).unwrap_or(0);
    if let Some(i) = s.values.iter().position(|v| !v.is_finite()) {
        return Err(StageError::Input(format!(
            "{}: row {} (script `{}`, frame {}), control `{}` is {}; rerun the stage that wrote it",
            path.display(),
            first_row + i / n.max(1),
            s.name,
            s.frame.get(i / n.max(1)).copied().unwrap_or(-1),
            controls.get(i % n.max(1)).map_or("?", String::as_str),
            s.values[i]
        )));
    }
    Ok(Played {
        controls: s.values.chunks_exact(n.max(1)).take(frames).map(<[f64]>::to_vec).collect(),
        model: s.model,
        x: s.x,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use reprise_artifact::curves::Curves;

    fn read_all(path: &Path, controls: &[String]) -> StageResult<BTreeMap<i64, Played>> {
        PlayedStream::open(path, controls)?.collect()
    }

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
            .or_else(|| read_all(&path, &controls).err().map(|e| e.to_string()));
        let e = refused.expect("a NaN control must not load");
        assert!(e.contains("curves.parquet") && (e.contains("NaN") || e.contains("finite")), "{e}");
        c.values[3] = 0.3;
        curves::write(&path, &c, &provenance).unwrap();
        assert_eq!(read_all(&path, &controls).unwrap()[&7].controls[1], vec![0.2, 0.3]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Scripts stream in request order; one that comes back to an earlier request (a
    /// script split in two, or out of order) is refused naming the file and the script,
    /// and scripts not named `r<id>` are skipped.
    #[test]
    fn scripts_out_of_request_order_are_refused() {
        let dir = std::env::temp_dir().join(format!("reprise-order-curves-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let controls = vec!["jaw".to_string()];
        let provenance = reprise_artifact::Provenance::new("t", "0", serde_json::json!({}));
        let path = dir.join("curves.parquet");
        let mut c = Curves { fps: 24.0, controls: controls.clone(), ..Default::default() };
        for name in ["r1", "demo", "r4", "r2"] {
            c.push_script(name, [curves::Frame::plain("a", &[0.5])]);
        }
        curves::write(&path, &c, &provenance).unwrap();
        let mut stream = PlayedStream::open(&path, &controls).unwrap();
        assert_eq!(stream.next().unwrap().unwrap().0, 1);
        assert_eq!(stream.next().unwrap().unwrap().0, 4, "`demo` is skipped");
        let e = stream.next().unwrap().unwrap_err().to_string();
        assert!(e.contains("curves.parquet") && e.contains("`r2`") && e.contains("request order"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
