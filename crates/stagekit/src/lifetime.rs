//! A stage lives no longer than the runner that started it. The runner puts each stage
//! in its own process group (so it can stop the stage and whatever the stage started
//! with one signal) and names itself in [`RUNNER_PID_ENV`]; a stage that sees that
//! variable asks the kernel to kill it when its parent dies (Linux `PR_SET_PDEATHSIG`),
//! and elsewhere polls its parent from a watchdog thread. Without this, a `kill -9` of
//! `reprise run` left the stage running, and it later overwrote the outputs of the next
//! run. A stage run by hand (no variable) is not affected.

/// Environment variable: the pid of the `reprise` runner that started this stage.
pub const RUNNER_PID_ENV: &str = "REPRISE_RUNNER_PID";

/// Makes this process die with the runner named in [`RUNNER_PID_ENV`], if any; exits at
/// once (code 1) when the runner is already gone.
pub fn die_with_runner() {
    let Some(runner) = std::env::var(RUNNER_PID_ENV).ok().and_then(|v| v.parse::<u32>().ok()) else { return };
    #[cfg(target_os = "linux")]
    {
        // If this fails the watchdog below still runs.
        let armed = rustix::process::set_parent_process_death_signal(Some(rustix::process::Signal::KILL)).is_ok();
        // The runner may have died between our fork and the line above.
        exit_if_orphaned(runner);
        if armed {
            return;
        }
    }
    #[cfg(unix)]
    {
        exit_if_orphaned(runner);
        let _ = std::thread::Builder::new().name("runner-watchdog".into()).spawn(move || loop {
            std::thread::sleep(std::time::Duration::from_millis(200));
            exit_if_orphaned(runner);
        });
    }
}

#[cfg(unix)]
fn exit_if_orphaned(runner: u32) {
    if std::os::unix::process::parent_id() != runner {
        eprintln!("reprise stage: the runner (pid {runner}) is gone; stopping");
        std::process::exit(crate::exit::FAILURE);
    }
}
