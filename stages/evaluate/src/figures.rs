//! The page's content besides the metric rows: figure data (latent spaces and bridges,
//! bridge poses, the filmstrip, fit traces, latency distributions), the player
//! ([`crate::player`]), what the inputs lack, and the provenance lines (commit, pipeline
//! hash, machine, inputs, stage times).

use std::collections::BTreeMap;
use std::path::Path;

use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::transitions::Request;
use reprise_artifact::{bridges, curves};
use reprise_numerics::gplvm::LatentModel;
use reprise_stagekit::rig::meshes;
use reprise_stagekit::StageResult;

use crate::charts::LatentPanel;
use crate::measure::Measured;
use crate::systems::System;
use crate::training::{RigRef, Training};
use crate::{html, player, Args};
use reprise_benchmark::systems::SYSTEMS;

/// What the page is built from.
pub struct Inputs<'a> {
    /// The stage's flags (input paths).
    pub args: &'a Args,
    /// The rig.
    pub rig: RigRef<'a>,
    /// The training reference.
    pub training: &'a Training,
    /// The labeled frames.
    pub labeled: &'a LabeledFrames,
    /// The requests.
    pub requests: &'a [Request],
    /// The systems given, and their measurements (same order).
    pub systems: &'a [System],
    /// Per system its measured answers.
    pub measured: &'a [Vec<Measured>],
    /// Per system its perceived latency per request that arrived (seconds).
    pub arrivals: &'a player::Arrivals,
    /// The bridges.
    pub links: &'a [bridges::Bridge],
    /// Label order.
    pub labels: &'a [String],
    /// A training pose's mesh (fixes the static renders' camera).
    pub camera_mesh: &'a [f64],
    /// The Markdown report.
    pub markdown: &'a str,
    /// Mean peak-speed traces: (system, offsets, values).
    pub speed: Vec<(String, Vec<i64>, Vec<f64>)>,
}

/// M's controls at latent point `x` (the GPLVM mean map).
pub fn pose(m: &LatentModel, x: &[f64]) -> Vec<f64> {
    let mut p = vec![0.0; m.controls()];
    m.controls_into(x, &mut vec![0.0; m.d()], &mut p);
    p
}

/// The page's content.
pub fn figures<'a>(inp: Inputs<'a>, provenance: &reprise_artifact::Provenance) -> StageResult<html::Page<'a>> {
    let args = inp.args;
    let lat = reprise_artifact::gplvm::read_latents(&args.io.latents)?;
    let latents: Vec<LatentPanel> = inp
        .labels
        .iter()
        .map(|l| {
            let mut segs: BTreeMap<i64, Vec<[f64; 2]>> = BTreeMap::new();
            for r in (0..lat.label.len()).filter(|&r| &lat.label[r] == l) {
                segs.entry(lat.segment_id[r]).or_default().push(xy(&lat.x[r]));
            }
            LatentPanel { label: l.clone(), segments: segs.into_values().collect() }
        })
        .collect();
    let index = |l: &str| inp.labels.iter().position(|x| x == l);
    let mut best: Vec<&bridges::Bridge> = inp.links.iter().filter(|b| b.rank == 1).collect();
    let latent_bridges =
        best.iter().filter_map(|b| Some((index(&b.from)?, xy(&b.x1), index(&b.to)?, xy(&b.x2)))).collect();
    let models = reprise_label_models::load(&args.io.gplvm_models, &args.io.pca_models, &args.io.scales)?;
    best.sort_by(|a, b| {
        a.mesh_distance.unwrap_or(a.rig_distance).total_cmp(&b.mesh_distance.unwrap_or(b.rig_distance))
    });
    let mut bridge_figs = Vec::new();
    for b in best.into_iter().take(6) {
        let (m1, m2) = (models.require(&b.from)?, models.require(&b.to)?);
        let poses = meshes(inp.rig, &[pose(m1, &b.x1), pose(m2, &b.x2)])?;
        let half = poses.len() / 2;
        let caption = format!("{} → {} (mesh distance {:.3})", b.from, b.to, b.mesh_distance.unwrap_or(f64::NAN));
        bridge_figs.push((caption, poses[..half].to_vec(), poses[half..].to_vec()));
    }
    let synth = curves::read(&args.io.curves)?;
    let filmstrip = filmstrip(inp.rig, &synth)?;
    let mut missing = missing(inp.systems, inp.requests, inp.labels);
    let player = player::build(&player::Inputs {
        arrivals: inp.arrivals,
        rig: inp.rig,
        training: inp.training,
        labeled: inp.labeled,
        requests: inp.requests,
        systems: inp.systems,
        bridges: inp.links,
        models: &models,
        curves: &synth,
        labels: inp.labels,
        window: args.window,
    })?;
    if player.groups.is_empty() {
        missing.push("No transition request to play: the player shows the synthesized scripts only.".into());
    }
    let traces = match &args.io.gplvm_trace {
        Some(p) => traces(p)?,
        None => {
            missing.push("No GPLVM trace given (--gplvm-trace): the fit-trace figure is empty.".into());
            vec![]
        }
    };
    let fits = fit_rows(&args.io.gplvm_fits)?;
    let latencies = inp
        .systems
        .iter()
        .zip(inp.measured)
        .map(|(s, per)| {
            let arrived: Vec<f64> = per.iter().filter_map(|m| m.perceived_latency).collect();
            (s.shown.clone(), inp.requests.len() - arrived.len(), arrived)
        })
        .map(|(shown, never, arrived)| (shown, arrived, never))
        .collect();
    Ok(html::Page {
        name: &args.name,
        markdown: inp.markdown,
        latents,
        latent_bridges,
        bridges: bridge_figs,
        filmstrip,
        shape: crate::render::Shape::of(inp.rig.0.as_ref()),
        camera_mesh: inp.camera_mesh,
        speed: inp.speed,
        latencies,
        traces,
        fits,
        labels: inp.labels,
        player: Some(player),
        missing,
        provenance: provenance_lines(args, provenance),
    })
}

/// The first two latent coordinates (0 where there are fewer).
fn xy(x: &[f64]) -> [f64; 2] {
    [x.first().copied().unwrap_or(0.0), x.get(1).copied().unwrap_or(0.0)]
}

/// Every 12th frame (0.5 s) of the first synthesized script, at most 16.
fn filmstrip(rig: RigRef<'_>, synth: &curves::Curves) -> StageResult<Option<(String, Vec<html::Picture>)>> {
    let Some(name) = synth.script.first().cloned() else { return Ok(None) };
    let n = synth.controls.len();
    let rows: Vec<usize> = (0..synth.script.len()).filter(|&r| synth.script[r] == name).step_by(12).take(16).collect();
    let poses: Vec<Vec<f64>> = rows.iter().map(|&r| synth.values[r * n..(r + 1) * n].to_vec()).collect();
    let m = meshes(rig, &poses)?;
    let d = m.len() / poses.len().max(1);
    let frames = rows
        .iter()
        .enumerate()
        .map(|(i, &r)| (format!("{} · {:.1} s", synth.model[r], synth.time[r]), m[i * d..(i + 1) * d].to_vec()))
        .collect();
    Ok(Some((format!("Script `{name}`, every 12th frame (0.5 s), captioned with the model that made it."), frames)))
}

/// What the inputs lack, one sentence each: systems of [`SYSTEMS`] not given, ordered label
/// pairs without requests, and pairs a given system answered none of.
pub fn missing(systems: &[System], requests: &[Request], labels: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for def in SYSTEMS.iter().filter(|d| !systems.iter().any(|s| s.id == d.id)) {
        let (id, shown) = (def.id, def.shown);
        out.push(format!(
            "{shown} (`{id}`) was not given to this run: it is absent from every table, figure and the player."
        ));
    }
    let mut none = Vec::new();
    let mut unanswered: Vec<Vec<(&str, &str)>> = vec![Vec::new(); systems.len()];
    for a in labels {
        for b in labels.iter().filter(|b| *b != a) {
            let reqs: Vec<&Request> = requests.iter().filter(|r| &r.from == a && &r.to == b).collect();
            if reqs.is_empty() {
                none.push((a.as_str(), b.as_str()));
                continue;
            }
            for (s, u) in systems.iter().zip(&mut unanswered) {
                if !reqs.iter().any(|r| s.answered(r)) {
                    u.push((a.as_str(), b.as_str()));
                }
            }
        }
    }
    for (s, u) in systems.iter().zip(&unanswered).filter(|(_, u)| !u.is_empty()) {
        out.push(format!(
            "{} answered none of the requests of {} label pairs (the player shows them as “no answer”): {}.",
            s.shown,
            u.len(),
            pair_list(u)
        ));
    }
    if !none.is_empty() {
        let all = labels.len() * labels.len().saturating_sub(1);
        out.push(format!(
            "No requests for {} of the {all} ordered label pairs (`transitions` samples the pairs when one \
             request each would pass its --max-requests): {}.",
            none.len(),
            pair_list(&none)
        ));
    }
    out
}

/// The most pairs a note names one by one.
const PAIRS_NAMED: usize = 12;

/// `pairs` as `a → b, …`: all of them when few; else the first [`PAIRS_NAMED`], how many
/// more, and the target labels most of them go to (so that dozens of labels do not make
/// a wall of names).
fn pair_list(pairs: &[(&str, &str)]) -> String {
    let named: Vec<String> = pairs.iter().take(PAIRS_NAMED).map(|(a, b)| format!("{a} → {b}")).collect();
    if pairs.len() <= PAIRS_NAMED {
        return named.join(", ");
    }
    let mut into: Vec<(&str, usize)> = Vec::new();
    for (_, b) in pairs {
        match into.iter_mut().find(|(l, _)| l == b) {
            Some((_, n)) => *n += 1,
            None => into.push((b, 1)),
        }
    }
    into.sort_by(|x, y| y.1.cmp(&x.1).then(x.0.cmp(y.0)));
    let most: Vec<String> = into.iter().take(5).map(|(l, n)| format!("into `{l}` {n}")).collect();
    format!("{}, … and {} more (most: {})", named.join(", "), pairs.len() - PAIRS_NAMED, most.join(", "))
}

/// Per label (in file order) the objective by iteration, from a `gplvm_trace` table.
fn traces(path: &Path) -> StageResult<Vec<html::Trace>> {
    let t = reprise_artifact::gplvm::read_trace(path)?;
    let mut out: Vec<html::Trace> = Vec::new();
    for ((label, iteration), value) in t.label.iter().zip(&t.iteration).zip(&t.value) {
        match out.iter_mut().find(|(l, _)| l == label) {
            Some((_, v)) => v.push((*iteration, *value)),
            None => out.push((label.clone(), vec![(*iteration, *value)])),
        }
    }
    Ok(out)
}

/// Per label (in file order) the fit summary, from a `gplvm_fits` table.
fn fit_rows(path: &Path) -> StageResult<Vec<html::FitRow>> {
    Ok(reprise_artifact::gplvm::read_fits(path)?
        .into_iter()
        .map(|f| html::FitRow {
            iterations: f.stage_iterations.iter().map(i64::to_string).collect::<Vec<_>>().join("+"),
            label: f.label,
            frames: f.frames,
            d: f.d,
            path: f.connectivity_path,
            optimizer: f.optimizer,
            evaluations: f.evaluations,
            seconds: f.seconds,
            objective: f.objective,
            likelihood: f.neg_log_likelihood,
            dynamics: f.dynamics,
            connectivity: f.connectivity,
            signal: f.signal,
            connectivity_exact: f.connectivity_exact,
            inducing: f.inducing_points,
            converged: f.converged,
            stop_reason: f.stop_reason,
            rel_decrease: f.rel_decrease,
            rel_gradient: f.rel_gradient,
        })
        .collect())
}

/// The provenance lines: stage, commit, pipeline hash, machine, inputs, stage times.
fn provenance_lines(args: &Args, provenance: &reprise_artifact::Provenance) -> Vec<(String, String)> {
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or("unknown".into(), |o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let pipeline = reprise_artifact::provenance::hash_file(Path::new("pipeline.toml"))
        .unwrap_or_else(|_| "no pipeline.toml beside the run".into());
    let mut prov = vec![
        ("stage".to_string(), format!("{} {}", provenance.stage, provenance.stage_version)),
        ("commit".to_string(), commit),
        ("pipeline.toml blake3".to_string(), pipeline),
        ("machine".to_string(), machine()),
    ];
    for (role, input) in &provenance.inputs {
        prov.push((
            format!("input {role}"),
            format!("{} (blake3 {})", input.path, &input.blake3[..16.min(input.blake3.len())]),
        ));
    }
    if let Some(lock) = args.lock.as_ref().and_then(|p| std::fs::read_to_string(p).ok()) {
        prov.extend(stage_times(&lock));
    }
    prov
}

/// CPU model and cores, from /proc/cpuinfo where there is one.
fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = info
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .unwrap_or("unknown")
        .trim()
        .to_string();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{model}, {cores} cores")
}

/// Per stage of the run's lock file (JSON): its seconds, and for a partitioned stage one
/// line summing its partitions (how many, their seconds in all, the longest named) — a
/// line per partition would be thousands with dozens of labels. A lock that does not
/// read as JSON gives nothing.
fn stage_times(lock: &str) -> Vec<(String, String)> {
    let Ok(lock) = serde_json::from_str::<serde_json::Value>(lock) else { return Vec::new() };
    let Some(stages) = lock.get("stages").and_then(|s| s.as_object()) else { return Vec::new() };
    let mut out = Vec::new();
    for (stage, entry) in stages {
        if let Some(seconds) = entry.get("seconds").and_then(serde_json::Value::as_f64) {
            out.push((format!("seconds {stage}"), format!("{seconds:.2}")));
        }
        let parts: Vec<(&String, f64)> = entry
            .get("partitions")
            .and_then(|p| p.as_object())
            .map(|p| p.iter().filter_map(|(name, r)| Some((name, r.get("seconds")?.as_f64()?))).collect())
            .unwrap_or_default();
        if let Some((longest, most)) = parts.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            let total: f64 = parts.iter().map(|p| p.1).sum();
            out.push((
                format!("partitions {stage}"),
                format!("{} run apart, {total:.2} s in all; the longest `{longest}`, {most:.2} s", parts.len()),
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    /// Few pairs are named one by one; many are cut at twelve, counted, and summarised by
    /// the labels they go into.
    #[test]
    fn long_pair_lists_are_summarised() {
        assert_eq!(super::pair_list(&[("a", "b"), ("b", "a")]), "a → b, b → a");
        let labels = ["a", "b", "c", "d", "e", "f"];
        let pairs: Vec<(&str, &str)> =
            labels.iter().flat_map(|&a| labels.iter().filter(move |&&b| b != a).map(move |&b| (a, b))).collect();
        let text = super::pair_list(&pairs);
        assert!(text.starts_with("a → b, a → c, a → d, a → e, a → f, b → a,"), "{text}");
        assert!(
            text.contains("… and 18 more (most: into `a` 5, into `b` 5, into `c` 5, into `d` 5, into `e` 5)"),
            "{text}"
        );
    }

    /// A stage's seconds, and one line for all the partitions of a partitioned stage with
    /// the longest named; not JSON, nothing.
    #[test]
    fn stage_times_sum_the_partitions() {
        let lock = r#"{"version": 1, "stages": {
            "bridges": {"seconds": 12.5, "partitions": {"a → b": {"seconds": 3.0}, "b → a": {"seconds": 4.25}}},
            "ingest": {"seconds": 0.5}
        }}"#;
        let t = super::stage_times(lock);
        assert_eq!(
            t,
            [
                ("seconds bridges".to_string(), "12.50".to_string()),
                (
                    "partitions bridges".to_string(),
                    "2 run apart, 7.25 s in all; the longest `b → a`, 4.25 s".to_string()
                ),
                ("seconds ingest".to_string(), "0.50".to_string()),
            ]
        );
        assert!(super::stage_times("not json").is_empty());
    }
}
