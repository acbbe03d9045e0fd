//! A stage lives no longer than its runner: `kill -9` of `reprise run` mid-stage, or a
//! SIGTERM, leaves no stage process behind, no temporary file, and the next run's
//! outputs are exactly those of a clean run (the issue: an orphaned `reprise-pca` kept
//! running and overwrote the rerun's outputs).

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::util::Project;

const PCA_OUTPUTS: [&str; 3] = ["pca_models", "pca_coords", "pca_errors"];

/// `reprise run ARGS` in the project, not waited for.
fn spawn(p: &Project, args: &[&str]) -> Child {
    let exe = Path::new(env!("CARGO_BIN_EXE_reprise"));
    Command::new(exe)
        .args(args)
        .current_dir(p.dir.path())
        .env("REPRISE_BIN_DIR", exe.parent().unwrap())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Pids of live processes whose working directory is the project and whose name
/// starts with `reprise-` (the stages; the runner is plain `reprise`).
fn stages_running_in(p: &Project) -> Vec<(u32, String)> {
    let dir = p.dir.path().canonicalize().unwrap();
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else { continue };
        let comm = std::fs::read_to_string(entry.path().join("comm")).unwrap_or_default();
        let state = std::fs::read_to_string(entry.path().join("stat")).unwrap_or_default();
        let zombie = state.rsplit(')').next().is_some_and(|rest| rest.trim_start().starts_with('Z'));
        if comm.starts_with("reprise-")
            && !zombie
            && std::fs::read_link(entry.path().join("cwd")).ok() == Some(dir.clone())
        {
            found.push((pid, comm.trim().to_string()));
        }
    }
    found
}

/// Waits until a `reprise-pca` runs in the project and has worked for a moment.
fn wait_for_pca(p: &Project, runner: &mut Child) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while !stages_running_in(p).iter().any(|(_, name)| name == "reprise-pca") {
        assert!(runner.try_wait().unwrap().is_none(), "the runner ended before pca started");
        assert!(Instant::now() < deadline, "pca never started");
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_millis(1500));
}

fn signal(pid: u32, signal: &str) {
    assert!(Command::new("kill").args([signal, &pid.to_string()]).status().unwrap().success());
}

/// Waits (up to 5 s) for every stage process of the project to be gone.
fn assert_no_stage_survives(p: &Project, when: &str) {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let left = stages_running_in(p);
        if left.is_empty() {
            return;
        }
        assert!(Instant::now() < deadline, "{when}: stage processes survive: {left:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn temp_files(p: &Project) -> Vec<String> {
    let dir = p.path("artifacts/dragon-face");
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

fn pca_bytes(p: &Project) -> Vec<Vec<u8>> {
    PCA_OUTPUTS.iter().map(|o| std::fs::read(p.path(&format!("artifacts/dragon-face/{o}.parquet"))).unwrap()).collect()
}

/// The default pipeline with pca's `variance` set.
fn set_variance(p: &Project, variance: &str) {
    let default = std::fs::read_to_string(crate::util::repo().join("pipeline.toml")).unwrap();
    let text = default.replace("variance = 0.85", &format!("variance = {variance}"));
    p.write("pipeline.toml", &text);
}

#[test]
fn killed_runner_leaves_no_stage_no_temp_and_a_clean_rerun() {
    // The reference: a clean run at the changed parameter.
    let clean = Project::dragon_face();
    set_variance(&clean, "0.9");
    clean.reprise(&["run", "--to", "pca"]).ok();
    let expected = pca_bytes(&clean);

    let p = Project::dragon_face();
    p.reprise(&["run", "--to", "pca"]).ok();
    let before = pca_bytes(&p);
    set_variance(&p, "0.87");

    // SIGTERM: the runner stops pca's process group and exits 128 + 15.
    let mut runner = spawn(&p, &["run", "--to", "pca"]);
    wait_for_pca(&p, &mut runner);
    signal(runner.id(), "-TERM");
    let out = runner.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(143), "{stderr}");
    // pca runs one label at a time: the label running is named, `pca[<label>]`.
    assert!(stderr.contains("interrupted by SIGTERM while stage `pca["), "{stderr}");
    assert_no_stage_survives(&p, "after SIGTERM");
    assert_eq!(pca_bytes(&p), before, "a stopped stage replaces none of its outputs");

    // kill -9: nothing can run in the runner; the stage dies with it.
    let mut runner = spawn(&p, &["run", "--to", "pca"]);
    wait_for_pca(&p, &mut runner);
    signal(runner.id(), "-KILL");
    runner.wait().unwrap();
    // Rerun at once with another parameter.
    set_variance(&p, "0.9");
    let out = p.reprise(&["run", "--to", "pca"]).ok();
    // (The stopped run kept only the labels that finished — none, each was stopped — and
    // pca's own key stays empty: nothing of it is trusted, every label reruns.)
    assert!(out.contains("running pca") && out.contains("pca: 8 of 8 labels to run"), "{out}");
    assert_no_stage_survives(&p, "after kill -9 and a rerun");
    assert_eq!(temp_files(&p), Vec::<String>::new());
    assert!(pca_bytes(&p) == expected, "rerun outputs differ from a clean run's");
    p.reprise(&["run", "--to", "pca"]).ok();
}

/// The two-label curve project of `scale_pca` whose reference evaluator hangs on its second
/// batch (the first is the rest pose): `scale` is then busy with a busy evaluator.
fn project_with_a_hanging_evaluator() -> Project {
    let rig = env!("CARGO_BIN_EXE_reprise-example-rig");
    crate::scale_pca::linear_project(&[rig, "--vertices", "5", "--hang-after", "1"])
}

/// Waits until a rig evaluator (`reprise-example-rig`, whose name the kernel cuts to 15
/// characters) and `reprise-scale` both run in the project; returns the stage's pid.
fn wait_for_busy_evaluator(p: &Project, runner: &mut Child) -> u32 {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let running = stages_running_in(p);
        let scale = running.iter().find(|(_, n)| n == "reprise-scale").map(|(pid, _)| *pid);
        if let (Some(scale), true) = (scale, running.iter().any(|(_, n)| n == "reprise-example")) {
            std::thread::sleep(Duration::from_millis(300));
            return scale;
        }
        assert!(runner.try_wait().unwrap().is_none(), "the runner ended before scale's evaluator was busy");
        assert!(Instant::now() < deadline, "no busy evaluator: {running:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `kill -9` of the runner, and of the stage, while a rig evaluator is busy: no stage and
/// no evaluator is left running (they were left with parent 1).
#[test]
fn a_busy_evaluator_dies_with_its_stage_and_runner() {
    let p = project_with_a_hanging_evaluator();
    let mut runner = spawn(&p, &["run", "--to", "scale"]);
    wait_for_busy_evaluator(&p, &mut runner);
    signal(runner.id(), "-KILL");
    runner.wait().unwrap();
    assert_no_stage_survives(&p, "after kill -9 of the runner");

    let mut runner = spawn(&p, &["run", "--to", "scale"]);
    let stage = wait_for_busy_evaluator(&p, &mut runner);
    signal(stage, "-KILL");
    let out = runner.wait_with_output().unwrap();
    assert!(!out.status.success(), "a killed stage fails the run");
    assert_no_stage_survives(&p, "after kill -9 of the stage");
}
