//! The Slurm executor for real: a one-node cluster (munged, slurmctld, slurmd from
//! Debian's `slurm-wlm` and `munge`) started by the test with `tests/slurm/start-slurm.sh`,
//! the dragon-face pipeline up to `gplvm` run with `--executor slurm`, and compared with
//! a local run. Skipped, saying so, where Slurm is not installed or the test is not root
//! (CI installs it and runs as root).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::{repo, Project};

/// A running one-node cluster; stopped (and its state removed) when dropped.
struct Cluster {
    lab: tempfile::TempDir,
}

impl Cluster {
    /// Starts the cluster, or `None` (after saying why) where it cannot run here.
    fn start(test: &str) -> Option<Self> {
        let installed = ["slurmctld", "slurmd", "munged", "sbatch"].iter().all(|b| {
            Command::new("sh").arg("-c").arg(format!("command -v {b}")).output().is_ok_and(|o| o.status.success())
        });
        let root = Command::new("id").arg("-u").output().is_ok_and(|o| o.stdout.starts_with(b"0\n"));
        if !installed || !root {
            eprintln!(
                "SKIPPED {test}: needs Debian's slurm-wlm and munge (installed: {installed}) and root (root: {root}); \
                 .ci/run installs them"
            );
            return None;
        }
        // The guard first: if the start fails half way, dropping it stops what did start.
        let cluster = Self { lab: tempfile::tempdir().unwrap() };
        // Ports of its own, so a cluster already running here is not disturbed.
        let port = || std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port().to_string();
        let out = Command::new(repo().join("tests/slurm/start-slurm.sh"))
            .env("SLURM_LAB", cluster.lab.path())
            .env("SLURM_LAB_CTLD_PORT", port())
            .env("SLURM_LAB_SLURMD_PORT", port())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "start-slurm.sh failed:\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        Some(cluster)
    }

    fn conf(&self) -> PathBuf {
        self.lab.path().join("slurm.conf")
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(repo().join("tests/slurm/stop-slurm.sh"))
            .arg("--purge")
            .env("SLURM_LAB", self.lab.path())
            .output();
    }
}

/// The dragon-face pipeline with short fits.
fn project() -> Project {
    let p = Project::dragon_face();
    let toml = p.read("pipeline.toml").replace("max_iters = 10000", "max_iters = 15");
    p.write("pipeline.toml", &toml.replace("heldout_every = 10", "heldout_every = 0"));
    p
}

fn parquet_files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".parquet"))
        .collect();
    names.sort();
    names
}

#[test]
fn slurm_runs_what_a_local_run_runs() {
    let Some(cluster) = Cluster::start("slurm_runs_what_a_local_run_runs") else { return };
    let env = [("SLURM_CONF", cluster.conf())];
    let env: Vec<(&str, &Path)> = env.iter().map(|(k, v)| (*k, v.as_path())).collect();

    let local = project();
    local.reprise(&["run", "--to", "gplvm"]).ok();
    let slurm = project();
    let first = slurm.reprise_with(&["run", "--to", "gplvm", "--executor", "slurm"], &env).ok();
    assert!(first.contains("ran gplvm[neutral]") && first.contains("(Slurm "), "labels ran as array tasks\n{first}");

    // The same artifacts, byte for byte — but for the wall-clock seconds in the fit tables.
    let (a, b) = (local.path("artifacts/dragon-face"), slurm.path("artifacts/dragon-face"));
    let names = parquet_files(&a);
    assert_eq!(names, parquet_files(&b));
    assert!(names.len() >= 12, "{names:?}");
    for name in names.iter().filter(|n| !["gplvm_fits.parquet", "gplvm_trace.parquet"].contains(&n.as_str())) {
        assert!(std::fs::read(a.join(name)).unwrap() == std::fs::read(b.join(name)).unwrap(), "{name} differs");
    }
    let objective = |dir: &Path| {
        reprise_artifact::Table::read_any(&dir.join("gplvm_fits.parquet")).unwrap().f64("objective").unwrap().to_vec()
    };
    assert_eq!(objective(&a), objective(&b));

    // The lock records the jobs; nothing is left in flight; a second run submits nothing.
    let lock: serde_json::Value = serde_json::from_str(&slurm.read("artifacts/dragon-face/reprise.lock")).unwrap();
    let job = lock["stages"]["gplvm"]["partitions"]["neutral"]["job"].as_str().unwrap_or_default().to_string();
    assert!(job.contains('_'), "{}", lock["stages"]["gplvm"]);
    assert!(lock["stages"]["ingest"]["job"].is_string(), "{}", lock["stages"]["ingest"]);
    assert!(!b.join(".reprise.jobs").exists());
    let batches = std::fs::read_dir(b.join(".slurm")).unwrap().count();
    let second = slurm.reprise_with(&["run", "--to", "gplvm", "--executor", "slurm"], &env).ok();
    assert!(second.contains("up to date"), "{second}");
    assert_eq!(std::fs::read_dir(b.join(".slurm")).unwrap().count(), batches, "nothing submitted");
    let status = slurm.reprise_with(&["status"], &env).ok();
    assert!(!status.contains("in flight"), "{status}");
    killed_runner_leaves_no_unreported_job(&slurm, &env);
}

/// `kill -9` of the runner while its array runs: `status` lists the job, and the next run
/// cancels it before it starts, saying so; nothing is left in the queue.
fn killed_runner_leaves_no_unreported_job(p: &Project, env: &[(&str, &Path)]) {
    p.write("pipeline.toml", &p.read("pipeline.toml").replace("max_iters = 15", "max_iters = 10000"));
    let exe = Path::new(env!("CARGO_BIN_EXE_reprise"));
    let mut runner = Command::new(exe)
        .args(["run", "--to", "gplvm", "--executor", "slurm"])
        .current_dir(p.dir.path())
        .env("REPRISE_BIN_DIR", exe.parent().unwrap())
        .envs(env.iter().copied())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let jobs = p.path("artifacts/dragon-face/.reprise.jobs");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while !jobs.exists() && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    runner.kill().unwrap();
    runner.wait().unwrap();
    assert!(jobs.exists(), "the runner submitted a job within 60 s");
    let status = p.reprise_with(&["status"], env).ok();
    assert!(status.contains("in flight: stage `gplvm`, 8 task(s)"), "{status}");
    let dag = p.reprise_with(&["dag"], env).ok();
    assert!(dag.contains("in flight: stage `gplvm`"), "{dag}");

    p.write("pipeline.toml", &p.read("pipeline.toml").replace("max_iters = 10000", "max_iters = 15"));
    let rerun = p.reprise_with(&["run", "--to", "gplvm", "--executor", "slurm"], env).ok();
    assert!(
        rerun.contains("reprise: cancelled Slurm job") && rerun.contains("left running by an earlier run"),
        "{rerun}"
    );
    let queue = Command::new("squeue").arg("-h").envs(env.iter().copied()).output().unwrap();
    assert!(queue.status.success() && queue.stdout.is_empty(), "{}", String::from_utf8_lossy(&queue.stdout));
    a_failed_task_says_why(p, env);
}

/// A stage that fails on the cluster fails the run with its own exit code and message
/// (read from the task's log), and nothing is left in flight.
fn a_failed_task_says_why(p: &Project, env: &[(&str, &Path)]) {
    p.write("pipeline.toml", &p.read("pipeline.toml").replace("q = 3", "q = 12"));
    let out = p.reprise_with(&["run", "--to", "gplvm", "--executor", "slurm"], env).fails(4);
    assert!(out.contains("failed (exit code 4) in job") && out.contains("fewer than the latent dimension 12"), "{out}");
    assert!(!p.path("artifacts/dragon-face/.reprise.jobs").exists());
}
