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
    let mut unanswered: Vec<Vec<String>> = vec![Vec::new(); systems.len()];
    for a in labels {
        for b in labels.iter().filter(|b| *b != a) {
            let reqs: Vec<&Request> = requests.iter().filter(|r| &r.from == a && &r.to == b).collect();
            if reqs.is_empty() {
                none.push(format!("{a} → {b}"));
                continue;
            }
            for (s, u) in systems.iter().zip(&mut unanswered) {
                if !reqs.iter().any(|r| s.answered(r)) {
                    u.push(format!("{a} → {b}"));
                }
            }
        }
    }
    for (s, u) in systems.iter().zip(&unanswered).filter(|(_, u)| !u.is_empty()) {
        out.push(format!(
            "{} answered none of the requests of {} label pairs (the player shows them as “no answer”): {}.",
            s.shown,
            u.len(),
            u.join(", ")
        ));
    }
    if !none.is_empty() {
        out.push(format!("No requests for {} of the label pairs: {}.", none.len(), none.join(", ")));
    }
    out
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

/// `seconds <stage>` lines from the runner's lock file (its stage entries' `seconds`).
fn stage_times(lock: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut current: Option<String> = None;
    for line in lock.lines() {
        let t = line.trim();
        if line.starts_with("    \"") && !line.starts_with("     ") && t.ends_with('{') {
            current = t.split('"').nth(1).map(str::to_string);
        }
        if let (Some(stage), Some(v)) = (&current, t.strip_prefix("\"seconds\":")) {
            out.push((format!("seconds {stage}"), v.trim().trim_end_matches(',').to_string()));
        }
    }
    out
}
