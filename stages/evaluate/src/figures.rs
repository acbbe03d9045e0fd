//! The report's figures (latent spaces, bridge poses, the filmstrip) and its provenance
//! lines (commit, pipeline hash, machine, inputs, stage times).

use std::collections::BTreeMap;

use reprise_artifact::{bridges, curves};
use reprise_stagekit::rig::meshes;
use reprise_stagekit::StageResult;

use crate::{html, Args};

/// The figures' data and the provenance lines.
#[allow(clippy::too_many_arguments)]
pub fn figures<'a>(
    args: &'a Args,
    rig: &'a (Box<dyn reprise_rig::Rig>, reprise_rig::PoseLayout),
    links: &[bridges::Bridge],
    labels: &'a [String],
    systems: &'a [(String, String)],
    camera_mesh: &'a [f64],
    md: &'a str,
    speed: Vec<(String, Vec<i64>, Vec<f64>)>,
    provenance: &reprise_artifact::Provenance,
) -> StageResult<html::Page<'a>> {
    let lat = reprise_artifact::gplvm::read_latents(&args.latents)?;
    let latents = labels
        .iter()
        .map(|l| {
            let mut segs: BTreeMap<i64, Vec<[f64; 2]>> = BTreeMap::new();
            for r in (0..lat.label.len()).filter(|&r| &lat.label[r] == l) {
                segs.entry(lat.segment_id[r]).or_default().push([lat.x[r][0], lat.x[r].get(1).copied().unwrap_or(0.0)]);
            }
            (l.clone(), segs.into_values().collect())
        })
        .collect();
    let models = reprise_model::load(&args.gplvm_models, &args.pca_models, &args.scales)?;
    let pose = |m: &reprise_numerics::gplvm::LatentModel, x: &[f64]| {
        let mut p = vec![0.0; m.controls()];
        m.controls_into(x, &mut vec![0.0; m.d()], &mut p);
        p
    };
    let mut best: Vec<&bridges::Bridge> = links.iter().filter(|b| b.rank == 1).collect();
    best.sort_by(|a, b| {
        a.mesh_distance.unwrap_or(a.rig_distance).total_cmp(&b.mesh_distance.unwrap_or(b.rig_distance))
    });
    let mut bridge_figs = Vec::new();
    for b in best.into_iter().take(6) {
        let (m1, m2) = (models.require(&b.from)?, models.require(&b.to)?);
        let poses = meshes(rig, &[pose(m1, &b.x1), pose(m2, &b.x2)])?;
        let half = poses.len() / 2;
        let caption = format!("{} → {} (mesh distance {:.3})", b.from, b.to, b.mesh_distance.unwrap_or(f64::NAN));
        bridge_figs.push((caption, poses[..half].to_vec(), poses[half..].to_vec()));
    }
    let synth = curves::read(&args.curves)?;
    let filmstrip = match synth.script.first().cloned() {
        None => None,
        Some(name) => {
            let n = synth.controls.len();
            let rows: Vec<usize> =
                (0..synth.script.len()).filter(|&r| synth.script[r] == name).step_by(12).take(16).collect();
            let poses: Vec<Vec<f64>> = rows.iter().map(|&r| synth.values[r * n..(r + 1) * n].to_vec()).collect();
            let m = meshes(rig, &poses)?;
            let d = m.len() / poses.len().max(1);
            let frames = rows
                .iter()
                .enumerate()
                .map(|(i, &r)| (format!("{} · {:.1} s", synth.model[r], synth.time[r]), m[i * d..(i + 1) * d].to_vec()))
                .collect();
            Some((format!("Script `{name}`, every 12th frame (0.5 s), captioned with the model that made it."), frames))
        }
    };
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or("unknown".into(), |o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    let pipeline = reprise_artifact::provenance::hash_file(std::path::Path::new("pipeline.toml"))
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
    Ok(html::Page {
        name: &args.name,
        summary_md: md,
        latents,
        bridges: bridge_figs,
        filmstrip,
        triangles: rig.0.triangles(),
        camera_mesh,
        speed,
        labels,
        systems,
        provenance: prov,
    })
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
