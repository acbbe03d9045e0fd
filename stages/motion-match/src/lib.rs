//! The motion-match stage: the transition benchmark's requests answered by two more
//! systems, on the same start frames as every other system.
//!
//! - **motion matching** (Clavet 2016, Holden et al. 2020 — method.md §7.5): per training
//!   frame a feature vector of the top `features` principal coordinates $y$ of the scaled
//!   controls (one PCA over every labeled frame, so all labels share coordinates) at the
//!   frame and 4, 8 and 12 frames ahead, plus $\dot y$, group-normalised; from the request
//!   the database plays on and, every `search_interval` seconds (the first search at a
//!   seeded phase of that timer), jumps to the best frame of the requested label; every jump
//!   is inertialized in rig space by one critically damped spring per control with
//!   half-life `halflife` ([`reprise_matching`] has the search, the springs and the
//!   switch rule).
//! - **crossfade**, the floor every method must beat: on the request, the requested label's
//!   frame nearest the current pose in scaled control space, crossfaded in over
//!   `blend_frames` with the Motion Graphs blend weight while the current take plays on.
//!
//! A label whose clips are all too short for a system's window (12 frames of continuation
//! for motion matching's features, `blend_frames` for the crossfade) is served with the
//! longest window its clips allow, its longest clip's length minus 1 frames
//! ([`reprise_matching::Database::label_window`]); the stage says so once per run, naming
//! each such label and the window used. Only a label of one-frame clips cannot be
//! jumped into (its requests fail, saying why).
//!
//! Both play the request's start frame first (the frame at which it is asked: `asked` = 0),
//! then their output, until `hold` seconds after the end of the blend into B, or fail after
//! `timeout` seconds without reaching B. The database holds scaled controls
//! $z_j = w_j p_j$ ($w$ the scale weights averaged over labels); a control no label's mesh
//! depends on ($w_j = 0$) is carried with $w_j = 10^{-3}\min_{w_i>0} w_i$ so every output
//! unscales exactly.

use clap::Parser;
use rand::{Rng, SeedableRng};
use reprise_artifact::curves;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::scales;
use reprise_artifact::transitions::{self, Answer, Request};
use reprise_matching::{crossfade, transition, ControllerSettings, MatchError, Playback, TransitionRequest};
use reprise_model_library::matching::Corpus;
use reprise_stagekit::{StageError, StageResult};
use serde::Serialize;

reprise_stagekit::stage_io! {
    stage: "motion-match", bin: "reprise-motion-match",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the labeled frames (the database).
        labeled_frames: required "labeled_frames.parquet",
        /// Input: the scales (the scaled control space).
        scales: required "scales.parquet",
        /// Input: the transition requests.
        requests: required "transition_requests.parquet",
    }
    outputs {
        /// Output: motion matching's answers.
        mm_answers: artifact "answers_motion_matching.parquet",
        /// Output: motion matching's curves.
        mm_curves: artifact "transitions_motion_matching.parquet",
        /// Output: the crossfade's answers.
        crossfade_answers: artifact "answers_crossfade.parquet",
        /// Output: the crossfade's curves.
        crossfade_curves: artifact "transitions_crossfade.parquet",
    }
}

/// `reprise-motion-match`: motion matching and crossfade answers to the benchmark.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-motion-match", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Principal coordinates of the scaled controls per feature time (q).
    #[arg(long, default_value_t = 8)]
    pub features: usize,
    /// Seconds between motion matching's searches.
    #[arg(long, default_value_t = 0.1)]
    pub search_interval: f64,
    /// Inertialization half-life, seconds (0: hard cuts).
    #[arg(long, default_value_t = 0.1)]
    pub halflife: f64,
    /// Blend length of the crossfade, and the blend phase of both (frames; = the others').
    #[arg(long, default_value_t = 12)]
    pub blend_frames: usize,
    /// Seconds played after the blend into B.
    #[arg(long, default_value_t = 0.5)]
    pub hold: f64,
    /// Seconds without reaching B after which a request fails.
    #[arg(long, default_value_t = 10.0)]
    pub timeout: f64,
    /// Seed of the search timer's phase at each request (+ request id).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Controls of the answers' curves are stored to this fraction of their range in the
    /// training frames (a power-of-two grid; 0: exactly).
    #[arg(long, default_value_t = reprise_artifact::curves::BENCHMARK_RESOLUTION)]
    pub resolution: f64,
}

/// What the stage answered: per request, (motion matching's, the crossfade's) answer.
pub type Answered = Vec<(Request, [Answer; 2])>;

/// One system's answer and frames (label, controls) to one request.
type Reply = (Answer, Vec<(String, Vec<f64>)>);

impl Args {
    fn validate(&self) -> StageResult<()> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let non_negative = |v: f64| v.is_finite() && v >= 0.0;
        let valid = self.features >= 1
            && positive(self.search_interval)
            && non_negative(self.halflife)
            && non_negative(self.hold)
            && positive(self.timeout)
            && self.timeout <= 3600.0
            && (0.0..=0.1).contains(&self.resolution);
        if !valid {
            return Err(StageError::Config(
                "need --features >= 1, --search-interval > 0, --halflife >= 0, --hold >= 0, 0 < --timeout <= 3600, \
                 --resolution in [0, 0.1]"
                    .into(),
            ));
        }
        // As `synthesize` and the transition benchmark: a blend has at least one frame (0
        // silently made the crossfade a cut).
        if self.blend_frames == 0 {
            return Err(StageError::Config(
                "--blend-frames must be at least 1, as synthesize's blend_frames (0 would make the crossfade a cut)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// A playback as an answer: the start frame (asked), then the output up to `after`
/// frames past the first frame of B; none if B was not reached.
fn reply(corpus: &Corpus, start: usize, out: Result<Playback, MatchError>, after: usize, to: &str) -> Reply {
    let out = match out {
        Ok(p) => p,
        Err(e) => return (Answer::failed(corpus.why(e)), vec![]),
    };
    let Some(l) = out.latency else {
        return (Answer::failed(format!("did not reach `{to}` within the time-out")), vec![]);
    };
    let end = (l + after).min(out.len());
    let mut frames =
        vec![(corpus.labels[corpus.db.label(start) as usize].clone(), corpus.unscale(corpus.db.row(start)))];
    frames.extend((0..end).map(|k| {
        (corpus.labels[out.labels[k] as usize].clone(), corpus.unscale(&out.z[k * out.dim..(k + 1) * out.dim]))
    }));
    (Answer::reached(0, l as i64 + 1), frames)
}

/// Runs the stage; returns the requests with both systems' answers.
pub fn run(args: &Args) -> StageResult<Option<Answered>> {
    args.validate()?;
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let labeled = LabeledFrames::read(&args.io.labeled_frames)?;
    let weight = scales::mean_weights(&scales::read(&args.io.scales)?, &labeled.frames.controls);
    let reqs = transitions::read_requests(&args.io.requests)?;
    let corpus = Corpus::build(&labeled, &args.io.labeled_frames, &args.io.scales, weight, args.features)?;
    for line in corpus.short_windows(args.blend_frames) {
        eprintln!("{line}");
    }
    let fps = labeled.frames.fps;
    let timeout = (args.timeout * fps).ceil() as usize;
    let after = args.blend_frames + (args.hold * fps).round() as usize;
    let settings =
        ControllerSettings { search_interval: args.search_interval, halflife: args.halflife, exclude_radius: None };
    let interval = settings.interval_frames(fps);
    let bar = reprise_stagekit::progress(reqs.len() as u64, "motion-match");
    let outputs = [
        ("motion-matching", &args.io.mm_answers, &args.io.mm_curves),
        ("crossfade", &args.io.crossfade_answers, &args.io.crossfade_curves),
    ];
    let controls = &labeled.frames.controls;
    let resolution = curves::Resolution::relative(args.resolution, &labeled.frames.ranges());
    let mut writers = outputs
        .map(|(_, _, c)| curves::Writer::create(c, fps, controls, &provenance).with_resolution(resolution.clone()));
    let mut answered: Answered = Vec::with_capacity(reqs.len());
    let answer = |r: &Request| -> StageResult<(Request, [Reply; 2])> {
        let start = *corpus.rows.get(&(r.segment_id, r.frame)).ok_or_else(|| {
            StageError::Input(format!(
                "{}: request {} starts at segment {} frame {}, which {} does not have; rerun transitions",
                args.io.requests.display(),
                r.request,
                r.segment_id,
                r.frame,
                args.io.labeled_frames.display()
            ))
        })?;
        let Some(target) = corpus.labels.iter().position(|l| *l == r.to) else {
            let none = || (Answer::failed(format!("no frame of `{}` in the database", r.to)), vec![]);
            return Ok((r.clone(), [none(), none()]));
        };
        let target = target as u32;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed.wrapping_add(r.request as u64));
        let first_search = rng.gen_range(0..interval);
        let request = TransitionRequest { start, target, first_search, frames: timeout };
        let mm = reply(&corpus, start, transition(&corpus.db, &corpus.feats, &request, &settings), after, &r.to);
        let fade =
            reply(&corpus, start, crossfade(&corpus.db, start, target, args.blend_frames, timeout), after, &r.to);
        bar.inc(1);
        Ok((r.clone(), [mm, fade]))
    };
    // Requests are answered a chunk at a time and their frames written before the next.
    reprise_stagekit::par_map_chunked(&reqs, answer, |reply| {
        let (r, replies) = reply?;
        for (w, (_, frames)) in writers.iter_mut().zip(&replies) {
            w.push_script(&format!("r{}", r.request), frames.iter().map(|(l, p)| curves::Frame::plain(l, p)))?;
        }
        let [mm, fade] = replies;
        answered.push((r, [mm.0, fade.0]));
        Ok(())
    })?;
    bar.finish_and_clear();
    for (s, ((system, answers_path, _), w)) in outputs.into_iter().zip(writers).enumerate() {
        let rows: Vec<(i64, Answer)> = answered.iter().map(|(r, a)| (r.request, a[s].clone())).collect();
        transitions::write_answers(answers_path, system, &rows, &provenance)?;
        w.finish()?;
    }
    Ok(Some(answered))
}

#[cfg(test)]
mod tests {
    use super::*;
    use reprise_artifact::frames::Frames;
    use reprise_artifact::provenance::Provenance;
    use reprise_artifact::scales::Scale;

    /// Two labels of 60 frames each, two controls tracing phase-shifted sines (`b` is `a` a
    /// quarter period on), so every pose of `a` has a near twin in `b`. `a` is one take;
    /// `b` is cut into clips of `b_clip` frames (the last one holds what is left).
    fn write_inputs(dir: &std::path::Path, requests: &[Request], b_clip: usize) -> Args {
        let n = 60;
        let segment = |r: usize| if r < n { 0 } else { 1 + (r - n) / b_clip };
        let frame = |r: usize| if r < n { r } else { (r - n) % b_clip };
        let values: Vec<f64> = (0..2 * n)
            .flat_map(|r| {
                let t = (r % n) as f64 * 0.2 + if r < n { 0.0 } else { 1.5 };
                [t.sin(), t.cos()]
            })
            .collect();
        let lf = LabeledFrames {
            segment_id: (0..2 * n).map(|r| segment(r) as i64).collect(),
            label: (0..2 * n).map(|r| if r < n { "a".into() } else { "b".into() }).collect(),
            frames: Frames {
                fps: 24.0,
                controls: vec!["c0".into(), "c1".into()],
                clip: (0..2 * n).map(|r| format!("clip{}", segment(r))).collect(),
                frame: (0..2 * n).map(|r| frame(r) as i64).collect(),
                time: (0..2 * n).map(|r| frame(r) as f64 / 24.0).collect(),
                values,
            },
            masked_controls: vec![],
        };
        let prov = Provenance::new("test", "0", serde_json::json!({}));
        let p = |f: &str| dir.join(f).display().to_string();
        lf.write(std::path::Path::new(&p("lf.parquet")), &prov).unwrap();
        let scale = |label: &str, control: &str| Scale {
            label: label.into(),
            control: control.into(),
            mean: 0.0,
            std: 1.0,
            weight: 2.0,
            residual: 0.0,
            used: true,
            reason: String::new(),
        };
        let rows: Vec<Scale> = ["a", "b"].iter().flat_map(|l| ["c0", "c1"].map(|c| scale(l, c))).collect();
        reprise_artifact::scales::write(std::path::Path::new(&p("scales.parquet")), &rows, &prov).unwrap();
        transitions::write_requests(std::path::Path::new(&p("requests.parquet")), requests, &prov).unwrap();
        Args::parse_from([
            "x",
            "--labeled-frames",
            &p("lf.parquet"),
            "--scales",
            &p("scales.parquet"),
            "--requests",
            &p("requests.parquet"),
            "--mm-answers",
            &p("mm.parquet"),
            "--mm-curves",
            &p("mmc.parquet"),
            "--crossfade-answers",
            &p("cf.parquet"),
            "--crossfade-curves",
            &p("cfc.parquet"),
            "--features",
            "2",
        ])
    }

    fn request(id: i64, to: &str, segment_id: i64, frame: i64) -> Request {
        Request { request: id, from: "a".into(), to: to.into(), segment_id, clip: "clip0".into(), frame }
    }

    /// Both systems reach B; their curves start at the request's frame (asked = 0), hold
    /// the first frame of B at `latency`, unscale to the controls' own values (a frame of B
    /// replayed after the blend is a training frame, to the stored resolution), and carry
    /// the producing label.
    #[test]
    fn both_systems_answer_from_the_start_frame() {
        let dir = tempfile::tempdir().unwrap();
        let args = write_inputs(dir.path(), &[request(0, "b", 0, 10), request(1, "a", 0, 20)], 60);
        let answered = run(&args).unwrap().unwrap();
        assert_eq!(answered.len(), 2);
        let lf = LabeledFrames::read(&args.io.labeled_frames).unwrap();
        for (answers, curves_path) in
            [(&args.io.mm_answers, &args.io.mm_curves), (&args.io.crossfade_answers, &args.io.crossfade_curves)]
        {
            let a = transitions::read_answers(answers).unwrap();
            let c = curves::read(curves_path).unwrap();
            let rows: Vec<usize> = (0..c.script.len()).filter(|&r| c.script[r] == "r0").collect();
            // Stored to the benchmark's resolution: within half a grid step of the frame.
            let ranges = lf.frames.ranges();
            let start = &c.values[rows[0] * 2..rows[0] * 2 + 2];
            for ((got, want), range) in start.iter().zip(lf.frames.row(10)).zip(&ranges) {
                assert!((got - want).abs() <= 0.5 * args.resolution * range, "{}: starts at the request", a.system);
            }
            let l = a.get(0).unwrap().latency.unwrap() as usize;
            assert!(l >= 1 && c.model[rows[l]] == "b" && c.model[rows[l - 1]] == "a", "{}: latency {l}", a.system);
            // The last frame replays B: it is one of B's training frames (after the blend).
            let last = &c.values[rows[rows.len() - 1] * 2..rows[rows.len() - 1] * 2 + 2];
            let nearest = (60..120)
                .map(|r| lf.frames.row(r).iter().zip(last).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 0.02, "{}: settles on B's frames ({nearest})", a.system);
            // Asked for its own label: reached at once.
            assert!(a.get(1).unwrap().latency.is_some());
        }
    }

    /// The corpus the stage builds from `args`' inputs.
    fn corpus(args: &Args) -> Corpus {
        let labeled = LabeledFrames::read(&args.io.labeled_frames).unwrap();
        let weight = scales::mean_weights(&scales::read(&args.io.scales).unwrap(), &labeled.frames.controls);
        Corpus::build(&labeled, &args.io.labeled_frames, &args.io.scales, weight, args.features).unwrap()
    }

    /// A label of one-frame clips cannot be jumped into: both systems fail its requests,
    /// saying so by the label's name (not the library's index).
    #[test]
    fn a_label_too_short_to_serve_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let args = write_inputs(dir.path(), &[request(0, "b", 0, 10)], 1);
        run(&args).unwrap();
        for answers in [&args.io.mm_answers, &args.io.crossfade_answers] {
            let a = transitions::read_answers(answers).unwrap();
            let why = &a.get(0).unwrap().error;
            let want = "label `b` has no frame to jump to: a frame needs 1 frame of continuation in its segment";
            assert!(why.contains(want), "{}: {why}", a.system);
        }
        assert!(corpus(&args).short_windows(12).is_empty(), "no window at all, not a shorter one");
    }

    /// Regression (a studio character's label of 11-frame clips, window 12): neither system
    /// answered a request into it. Now both reach it, motion matching searching it with a
    /// 10-frame continuation and the crossfade blending over 10 frames, and the stage says
    /// so once; `a` (one 60-frame take) keeps the full windows.
    #[test]
    fn regression_eleven_frame_clips_are_answered_with_a_ten_frame_window() {
        let dir = tempfile::tempdir().unwrap();
        let args = write_inputs(dir.path(), &[request(0, "b", 0, 10), request(1, "b", 0, 40)], 11);
        run(&args).unwrap();
        for answers in [&args.io.mm_answers, &args.io.crossfade_answers] {
            let a = transitions::read_answers(answers).unwrap();
            for id in [0, 1] {
                let answer = a.get(id).unwrap();
                assert!(answer.latency.is_some(), "{} request {id}: {}", a.system, answer.error);
            }
        }
        assert_eq!(
            corpus(&args).short_windows(12),
            ["motion-match: label `b` (clips of at most 11 frames) is searched with a 10-frame continuation \
              instead of 12 and crossfaded into over 10 frames instead of 12"]
        );
    }

    /// A blend longer than every clip (61 frames on 60-frame takes) used to fail the
    /// crossfade; it now blends over 59 frames, and the stage names both labels. Motion
    /// matching's 12-frame continuation fits, so it is not mentioned.
    #[test]
    fn a_blend_longer_than_the_clips_is_shortened_and_said() {
        let dir = tempfile::tempdir().unwrap();
        let mut args = write_inputs(dir.path(), &[request(0, "b", 0, 10)], 60);
        args.blend_frames = 61;
        run(&args).unwrap();
        let a = transitions::read_answers(&args.io.crossfade_answers).unwrap();
        assert!(a.get(0).unwrap().latency.is_some(), "{}", a.get(0).unwrap().error);
        let line = |l: &str| {
            format!("motion-match: label `{l}` (clips of at most 60 frames) is crossfaded into over 59 frames instead of 61")
        };
        assert_eq!(corpus(&args).short_windows(61), [line("a"), line("b")]);
    }

    /// `--blend-frames 0` silently made the crossfade a cut; it is refused as synthesize
    /// refuses it.
    #[test]
    fn a_zero_frame_blend_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut args = write_inputs(dir.path(), &[request(0, "b", 0, 10)], 60);
        args.blend_frames = 0;
        let err = run(&args).unwrap_err();
        assert_eq!(err.code(), reprise_stagekit::exit::CONFIG);
        assert!(err.to_string().contains("--blend-frames must be at least 1"), "{err}");
    }

    /// A request starting at a frame the labeled frames do not have is refused, naming it.
    #[test]
    fn requests_of_another_corpus_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let args = write_inputs(dir.path(), &[request(7, "b", 5, 3)], 60);
        let err = run(&args).unwrap_err().to_string();
        assert!(err.contains("request 7 starts at segment 5 frame 3") && err.contains("rerun transitions"), "{err}");
        assert!(!args.io.mm_answers.exists(), "nothing written");
    }

    /// Bad parameters fail the check.
    #[test]
    fn bad_parameters_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let mut args = write_inputs(dir.path(), &[], 60);
        args.timeout = 0.0;
        assert!(run(&args).unwrap_err().to_string().contains("--timeout"));
    }
}
