//! A panic in a stage body reaches the user as one "internal error" line with where to
//! report it and exit code 1, never as a raw panic message and backtrace. The test runs
//! itself as a child process (the wrapper exits the process).

use std::process::Command;

const CHILD: &str = "REPRISE_STAGEKIT_PANIC_CHILD";

#[test]
fn a_panic_becomes_an_internal_error() {
    if std::env::var_os(CHILD).is_some() {
        reprise_stagekit::main("reprise-test", "reprise-code-id=test;", || {
            let v: Vec<u32> = Vec::new();
            let _ = std::hint::black_box(&v)[3];
            Ok(())
        });
    }
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "a_panic_becomes_an_internal_error", "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .env_remove("RUST_BACKTRACE")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(reprise_stagekit::exit::FAILURE), "{stderr}");
    assert!(stderr.contains("reprise-test: internal error: index out of bounds"), "{stderr}");
    assert!(stderr.contains("this is a bug in reprise") && stderr.contains("please report it"), "{stderr}");
    assert!(!stderr.contains("panicked at") && !stderr.contains("stack backtrace"), "{stderr}");
}
