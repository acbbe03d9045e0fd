//! The gplvm stage under the runner on the default corpus, with a short SCG budget: its
//! four artifacts, models that reload into latent → rig-control maps reproducing the
//! training frames' PCA reconstruction, the held-out check, and bad input.

use reprise_artifact::gplvm;
use reprise_artifact::pca;

use crate::util::Project;

/// The default pipeline with a short fit (the default budget is a benchmark's business).
fn short(p: &Project, iters: usize) {
    let toml = p
        .read("pipeline.toml")
        .replace("max_iters = 10000", &format!("max_iters = {iters}"))
        .replace("stride = 1", "stride = 5");
    assert!(toml.contains(&format!("max_iters = {iters}")), "the default pipeline sets max_iters");
    p.write("pipeline.toml", &toml);
}

#[test]
fn gplvm_fits_every_label_and_models_reconstruct() {
    let p = Project::dragon_face();
    short(&p, 40);
    // Labels of more than 450 frames take the sparse GPLVM (60 inducing points), so that
    // everything downstream runs on both kinds of model.
    let toml = p
        .read("pipeline.toml")
        .replace("heldout_every = 10", "heldout_every = 10\ndense_max_frames = 450\ninducing = 60");
    p.write("pipeline.toml", &toml);
    let out = p.reprise(&["run", "--to", "gplvm"]).ok();
    assert!(out.contains("gplvm"), "{out}");
    let a = |f: &str| p.path(&format!("artifacts/dragon-face/{f}.parquet"));
    let latents = gplvm::read_latents(&a("gplvm_latents")).unwrap();
    assert_eq!(latents.label.len(), 3745);
    assert!(latents.x.iter().all(|x| x.len() == 3 && x.iter().all(|v| v.is_finite())));
    let fits = gplvm::read_fits(&a("gplvm_fits")).unwrap();
    assert_eq!(fits.len(), 8);
    let sparse: Vec<&str> = fits.iter().filter(|f| f.inducing_points == 60).map(|f| f.label.as_str()).collect();
    assert!(fits.iter().all(|f| (f.inducing_points == 60) == (f.frames > 450)), "the per-label rule: {fits:?}");
    assert!(!sparse.is_empty() && sparse.len() < 8, "both kinds of fit: sparse {sparse:?}");
    assert!(fits.iter().all(|f| f.objective < f.initial_objective), "every fit lowers its objective");
    for f in &fits {
        let errors = [
            f.heldout_gplvm_mesh_rmse,
            f.heldout_pca_q_mesh_rmse,
            f.heldout_pca_d_mesh_rmse,
            f.generative_gplvm_mesh_rmse,
            f.generative_interp_mesh_rmse,
            f.generative_interp_d_mesh_rmse,
        ];
        assert!(errors.iter().all(|v| v.is_some_and(|v| v.is_finite() && v > 0.0)), "{f:?}");
        assert!((1..=f.d).contains(&f.heldout_d) && f.heldout_frames > 0, "{f:?}");
        assert!((1..=f.heldout_frames).contains(&f.generative_frames), "{f:?}");
    }
    let trace = reprise_artifact::Table::read(&a("gplvm_trace"), gplvm::GPLVM_TRACE).unwrap();
    assert!(trace.rows() >= 8 && trace.rows() <= 8 * 40);

    // The reloaded models: a training latent reconstructs its frame's PCA coordinates
    // through the GP, and its controls through the PCA basis and the unscaling.
    let models = reprise_label_models::load(&a("gplvm_models"), &a("pca_models"), &a("scales")).unwrap();
    assert_eq!(models.models.len(), 8);
    for m in &models.models {
        // A sparse model's mean runs over its 60 inducing points; every model keeps its latents.
        assert_eq!(m.predictor.is_sparse(), sparse.contains(&m.label.as_str()), "{}", m.label);
        let support = if m.predictor.is_sparse() { 60 } else { m.frames() };
        assert_eq!(m.predictor.n(), support, "{}", m.label);
        assert_eq!(m.frames(), latents.label.iter().filter(|l| **l == m.label).count());
    }
    let coords = pca::read_coords(&a("pca_coords")).unwrap();
    let m = models.require("roar").unwrap();
    let i = latents.label.iter().position(|l| l == "roar").unwrap();
    let row = (0..coords.label.len())
        .find(|&r| {
            coords.label[r] == "roar"
                && coords.variant[r] == "scaled"
                && coords.frame[r] == latents.frame[i]
                && coords.segment_id[r] == latents.segment_id[i]
        })
        .unwrap();
    let mut y = vec![0.0; m.d()];
    m.pca_coords(&latents.x[i], &mut y);
    let scale: f64 = coords.y[row].iter().map(|v| v * v).sum::<f64>().sqrt();
    let err: f64 = y.iter().zip(&coords.y[row]).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    assert!(err < 0.2 * scale, "training frame reconstructs: error {err} vs |y| {scale}");
    assert_eq!(m.controls(), models.controls.len());
    assert!(models.require("nope").unwrap_err().to_string().contains("roar"));

    // Nothing changed: gplvm is cached.
    assert!(!p.reprise(&["run", "--to", "gplvm"]).ok().contains("ran gplvm"));

    // Bridges under the data-derived threshold, and the shipped scripts synthesized through them.
    let out = p.reprise(&["run"]).ok();
    assert!(out.contains("ran bridges") && out.contains("ran synthesize"), "{out}");
    let bridges = reprise_artifact::bridges::read(&a("bridges")).unwrap();
    let pairs: std::collections::BTreeSet<(&str, &str)> =
        bridges.iter().map(|b| (b.from.as_str(), b.to.as_str())).collect();
    // The absolute threshold the stage derived from each pair's data (its table's last
    // column: from, to, candidates, at bound, under, kept, best, frame motion, max mesh), and the
    // bridges it kept: every one within its pair's, at most 50 a pair; a pair without one is
    // left to routing (the scripts still run below).
    let max: std::collections::BTreeMap<(String, String), f64> = out
        .lines()
        .filter_map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            let max = w.get(8)?.parse().ok().filter(|_| w.len() == 9 && w[2].parse::<usize>().is_ok())?;
            Some(((w[0].to_string(), w[1].to_string()), max))
        })
        .collect();
    assert_eq!(max.len(), 56, "a threshold for every ordered pair in {out}");
    assert!((1..=56).contains(&pairs.len()), "{} ordered pairs bridged", pairs.len());
    for (from, to) in &pairs {
        let n = bridges.iter().filter(|b| (b.from.as_str(), b.to.as_str()) == (*from, *to)).count();
        assert!(n <= 50, "{from} → {to} keeps {n} bridges");
    }
    assert!(bridges.iter().all(|b| {
        let limit = max[&(b.from.clone(), b.to.clone())];
        b.mesh_distance.is_some_and(|m| m.is_finite() && m <= limit + 1e-4) && b.rank >= 1
    }));
    let curves = reprise_artifact::curves::read(&a("curves")).unwrap();
    let scripts: std::collections::BTreeSet<&str> = curves.script.iter().map(String::as_str).collect();
    assert_eq!(scripts.into_iter().collect::<Vec<_>>(), ["neutral_moves", "tic_tac_toe", "tour"]);
    assert!(curves.values.iter().all(|v| v.is_finite()));
    let game: Vec<usize> = (0..curves.script.len()).filter(|&r| curves.script[r] == "tic_tac_toe").collect();
    let switches = game.windows(2).filter(|w| curves.model[w[0]] != curves.model[w[1]]).count();
    // Six TRANSITION commands, each direct or through a third label (labels without a direct
    // bridge are routed).
    assert!((6..=12).contains(&switches), "the game script's six transitions switch model {switches} times");
    // The baseline and the transition benchmark: every ordered pair asked 20 times.
    let nodes = reprise_artifact::motion_graph::read_nodes(&a("mg_nodes")).unwrap();
    assert_eq!(nodes.frame.len(), 3745);
    let kept = nodes.in_scc.iter().filter(|v| **v).count();
    assert!(kept > 0 && kept < 3745, "pruning keeps part of the graph: {kept}");
    let reqs = reprise_artifact::transitions::read_requests(&a("transition_requests")).unwrap();
    assert_eq!(reqs.len(), 56 * 20);
    // Neither system is guaranteed an answer; every unanswered request says why.
    let ours = reprise_artifact::transitions::read_answers(&a("answers_reprise")).unwrap();
    let theirs = reprise_artifact::transitions::read_answers(&a("answers_motion_graphs")).unwrap();
    assert_eq!((ours.system.as_str(), theirs.system.as_str()), ("reprise", "motion-graphs"));
    // Motion matching and the crossfade answer the same requests.
    for (file, system) in [("answers_motion_matching", "motion-matching"), ("answers_crossfade", "crossfade")] {
        let a = reprise_artifact::transitions::read_answers(&a(file)).unwrap();
        assert_eq!(a.system, system);
        assert!(reqs.iter().all(|r| a.get(r.request).is_some()), "{system} answers every request");
    }
    let answered = reqs.iter().filter(|r| ours.get(r.request).unwrap().latency.is_some()).count();
    assert!(answered * 2 > reqs.len(), "reprise answers {answered} of {}", reqs.len());
    for system in [&ours, &theirs] {
        assert!(reqs.iter().all(|r| system.get(r.request).is_some_and(|a| a.latency.is_some() || !a.error.is_empty())));
    }
    // The evaluation: metrics for both systems and a report that names where each wins.
    let metrics =
        reprise_artifact::Table::read(&p.path("reports/dragon-face/metrics.parquet"), reprise_evaluate::METRICS)
            .unwrap();
    let systems = metrics.strings("system").unwrap();
    assert!(systems.iter().any(|s| s == "reprise") && systems.iter().any(|s| s == "motion-graphs"));
    let names = metrics.strings("metric").unwrap();
    // Every system is measured on every headline metric, perceived latency included.
    for m in [
        "plausibility_floor_mesh_reach",
        "plausibility_raw_scaled_blend",
        "variety",
        "coverage",
        "success",
        "arrived",
        "perceived_latency_s",
        "discontinuity_accel",
        "liveliness_ks",
    ] {
        for s in ["reprise", "motion-graphs", "motion-matching", "crossfade"] {
            if m == "variety" && ["motion-matching", "crossfade"].contains(&s) {
                continue; // deterministic: shown as 0 by construction, not measured
            }
            assert!((0..names.len()).any(|r| names[r] == m && systems[r] == s), "no {s} {m}");
        }
    }
    for pair in [
        "reprise vs motion-graphs",
        "reprise vs motion-matching",
        "reprise vs crossfade",
        "motion-matching vs crossfade",
    ] {
        assert!(systems.iter().any(|s| s == pair), "no paired rows for {pair}");
    }
    assert!(systems.iter().any(|s| s == "requests") && names.iter().any(|m| m == "start_on_bridge"));
    let md = p.read("reports/dragon-face/report.md");
    assert!(md.contains("**Motion Graphs** is best on") && md.contains("## Definitions"), "{md}");
    assert!(!md.contains("by construction") && md.contains("- `perceived_latency_s`: "), "{md}");
    assert!(md.contains("of the requests start on a bridge point"), "{md}");
    assert!(md.contains("## Plausibility by phase") && md.contains("| floor | mesh | settle |"), "{md}");
    assert!(md.contains("**Motion matching** is best on") && md.contains("**Crossfade** is best on"), "{md}");
    let html = p.read("reports/dragon-face/index.html");
    for id in [
        "conclusions",
        "metrics",
        "transition-player",
        "traces",
        "latency",
        "latents",
        "bridges",
        "filmstrip",
        "velocity",
        "coverage",
    ] {
        assert!(html.contains(&format!("id='{id}'")), "the report has the {id} figure");
    }
    assert!(html.matches("data:image/png;base64,").count() >= 12, "rendered bridge poses and filmstrip frames");
    assert!(!html.contains("src='http") && !html.contains("src=\"http") && !html.contains("<link"), "self-contained");
    assert!(html.contains("id='player-data'") && html.contains("id='player-mesh'"), "the player's data is inline");
    transitions_refuses_a_graph_that_does_not_belong(&p);
    bridges_refuse_models_of_another_pca(&p);
    // The same seeds give the same curves.
    let before = std::fs::read(a("curves")).unwrap();
    p.reprise(&["run", "--force", "synthesize"]).ok();
    let again = reprise_artifact::curves::read(&a("curves")).unwrap();
    assert_eq!(again, curves);
    assert!(!before.is_empty());
}

#[test]
fn gplvm_bad_input_is_a_clear_error() {
    let p = Project::dragon_face();
    short(&p, 2);
    p.reprise(&["run", "--to", "pca"]).ok();
    // A label too small for q: ask for a 12-dimensional latent space from 5–8 PCA components.
    let toml = p.read("pipeline.toml").replace("q = 3", "q = 12");
    p.write("pipeline.toml", &toml);
    let err = p.reprise(&["run"]).fails(4);
    assert!(err.contains("label `") && err.contains("fewer than the latent dimension 12"), "{err}");
    assert!(!p.path("artifacts/dragon-face/gplvm_models.parquet").exists(), "nothing half-written");
    // A bad parameter fails the --check before anything runs.
    let toml = p.read("pipeline.toml").replace("q = 12", "q = 3").replace("heldout_every = 10", "heldout_every = 1");
    p.write("pipeline.toml", &toml);
    let err = p.reprise(&["run"]).fails(2);
    assert!(err.contains("--heldout-every"), "{err}");
    // The dense rule with the sparse fit disabled: a label above it is named, with the way out.
    let toml = p
        .read("pipeline.toml")
        .replace("heldout_every = 1", "heldout_every = 10\ndense_max_frames = 300\nsparse = \"never\"");
    p.write("pipeline.toml", &toml);
    let err = p.reprise(&["run"]).fails(2);
    assert!(
        err.contains("more than --dense-max-frames 300, and --sparse never") && err.contains("use --sparse auto"),
        "{err}"
    );
    // More inducing points than a label has frames.
    let toml = p.read("pipeline.toml").replace("sparse = \"never\"", "sparse = \"always\"\ninducing = 5000");
    p.write("pipeline.toml", &toml);
    let err = p.reprise(&["run"]).fails(2);
    assert!(err.contains("fewer than --inducing 5000"), "{err}");
    assert!(!p.path("artifacts/dragon-face/gplvm_models.parquet").exists(), "nothing half-written");
}

/// `reprise-transitions` run by hand on the full run's artifacts: a window other than the
/// motion graph's, and edges of another motion-graph run beside these nodes, are refused
/// as bad input naming the file — before any request is answered, nothing written.
fn transitions_refuses_a_graph_that_does_not_belong(p: &Project) {
    const A: &str = "artifacts/dragon-face";
    let args = |window: &str, edges: &str| -> Vec<String> {
        let mut v: Vec<String> = [
            ("gplvm-models", "gplvm_models"),
            ("latents", "gplvm_latents"),
            ("pca-models", "pca_models"),
            ("scales", "scales"),
            ("bridges", "bridges"),
            ("labeled-frames", "labeled_frames"),
            ("mg-nodes", "mg_nodes"),
        ]
        .iter()
        .flat_map(|(flag, file)| [format!("--{flag}"), format!("{A}/{file}.parquet")])
        .collect();
        v.extend(["--mg-edges".into(), edges.into(), "--window".into(), window.into()]);
        let reprise = ["reprise", "reprise-paper"]
            .into_iter()
            .flat_map(|s| ["answers", "curves", "reseeded"].into_iter().map(move |o| format!("{s}-{o}")));
        let ablation = ["live-idle", "landing-choice", "settle"]
            .into_iter()
            .flat_map(|s| ["answers", "curves"].into_iter().map(move |o| format!("{s}-{o}")));
        let mg = ["motion-graphs-answers", "motion-graphs-curves", "motion-graphs-reseeded"].map(String::from);
        for out in std::iter::once("requests".to_string()).chain(reprise).chain(ablation).chain(mg) {
            v.extend([format!("--{out}"), format!("out/t/{out}.parquet")]);
        }
        v
    };
    let run = |a: Vec<String>| p.stage("reprise-transitions", &a.iter().map(String::as_str).collect::<Vec<_>>());
    let edges = format!("{A}/mg_edges.parquet");

    let wide = run(args("24", &edges)).fails(reprise_stagekit::exit::INPUT);
    assert!(wide.contains("mg_nodes.parquet") && wide.contains("built with window 12"), "{wide}");

    let other =
        crate::bad_inputs::motion_graph("other", &format!("{A}/labeled_frames.parquet"), &["--quantile", "0.2"]);
    p.stage("reprise-motion-graph", &other.iter().map(String::as_str).collect::<Vec<_>>()).ok();
    let mixed = run(args("12", "out/other/e.parquet")).fails(reprise_stagekit::exit::INPUT);
    assert!(mixed.contains("out/other/e.parquet") && mixed.contains("mg_nodes.parquet"), "{mixed}");
    assert!(
        !p.path("out/t").exists() || std::fs::read_dir(p.path("out/t")).unwrap().next().is_none(),
        "nothing written"
    );
}

/// `reprise-bridges` run by hand with the run's GPLVM models beside PCA models of another
/// pca run (another variance share): refused as bad input naming both files, before any
/// bridge is searched, nothing written.
fn bridges_refuse_models_of_another_pca(p: &Project) {
    const A: &str = "artifacts/dragon-face";
    let a = |file: &str| format!("{A}/{file}.parquet");
    let pca = [
        "--labeled-frames",
        &a("labeled_frames"),
        "--scales",
        &a("scales"),
        "--controls",
        &a("controls"),
        "--models",
        "out/pca2/m.parquet",
        "--coords",
        "out/pca2/c.parquet",
        "--errors",
        "out/pca2/e.parquet",
        "--variance",
        "0.9",
        "--mesh-errors",
        "false",
    ];
    p.stage("reprise-pca", &pca).ok();
    let bridges = [
        "--gplvm-models",
        &a("gplvm_models"),
        "--pca-models",
        "out/pca2/m.parquet",
        "--scales",
        &a("scales"),
        "--controls",
        &a("controls"),
        "--labeled-frames",
        &a("labeled_frames"),
        "--bridges",
        "out/b2/bridges.parquet",
    ];
    let e = p.stage("reprise-bridges", &bridges).fails(reprise_stagekit::exit::INPUT);
    assert!(
        e.contains("gplvm_models.parquet: was made by `gplvm` from pca_models") && e.contains("out/pca2/m.parquet"),
        "{e}"
    );
    assert!(!p.path("out/b2/bridges.parquet").exists(), "nothing written");
}
