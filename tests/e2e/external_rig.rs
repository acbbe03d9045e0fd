//! The external rig protocol against the reference evaluator `reprise-example-rig`,
//! including evaluators that exit early, hang, or answer the wrong size.

use std::path::Path;
use std::time::Duration;

use reprise_rig::external::ExternalRig;
use reprise_rig::linear::LinearRig;
use reprise_rig::Rig;

fn names(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("c{i}")).collect()
}

fn spawn(flags: &[&str], timeout: Duration) -> Result<ExternalRig, reprise_rig::RigError> {
    let mut command = vec![env!("CARGO_BIN_EXE_reprise-example-rig").to_string(), "--vertices".into(), "7".into()];
    command.extend(flags.iter().map(|s| s.to_string()));
    ExternalRig::spawn_with_timeout(&command, Path::new("."), names(4), vec![0.0; 4], timeout)
}

/// The external process gives exactly what the in-process linear rig gives.
#[test]
fn external_matches_in_process() {
    let rig = spawn(&[], Duration::from_secs(20)).unwrap();
    assert_eq!(rig.vertex_count(), 7);
    let local = reprise_rig::Local::new(LinearRig::new(names(4), 7));
    let poses: Vec<f64> = (0..40).map(|i| f64::from(i) * 0.1 - 1.0).collect();
    let mut a = vec![0.0; 10 * 21];
    let mut b = vec![0.0; 10 * 21];
    rig.evaluate_batch(&poses, &mut a).unwrap();
    local.evaluate_batch(&poses, &mut b).unwrap();
    assert_eq!(a, b);
    // A second batch on the same process.
    rig.evaluate_batch(&poses[..4], &mut a[..21]).unwrap();
    assert_eq!(a[..21], b[..21]);
}

#[test]
fn evaluator_exiting_early() {
    let rig = spawn(&["--fail-after", "1"], Duration::from_secs(20)).unwrap();
    let err = rig.evaluate(&[1.0, 0.0, 0.0, 0.0]).unwrap_err().to_string();
    assert!(err.contains("before answering") && err.contains("failing on purpose"), "{err}");
}

#[test]
fn evaluator_hanging_times_out() {
    let rig = spawn(&["--hang-after", "1"], Duration::from_millis(500)).unwrap();
    let err = rig.evaluate(&[1.0, 0.0, 0.0, 0.0]).unwrap_err().to_string();
    assert!(err.contains("no answer within 0.5 s"), "{err}");
}

#[test]
fn evaluator_answering_wrong_size() {
    let rig = spawn(&["--wrong-count"], Duration::from_secs(20)).unwrap();
    let mut out = vec![0.0; 2 * 21];
    let err = rig.evaluate_batch(&[0.0; 8], &mut out).unwrap_err().to_string();
    assert!(err.contains("answered 1 poses for 2 sent"), "{err}");
}

/// An evaluator answering NaN is refused, naming the value, the vertex and the pose.
#[test]
fn evaluator_answering_nan() {
    let rig = spawn(&["--nan-after", "1"], Duration::from_secs(20)).unwrap();
    let mut out = vec![0.0; 21];
    let err = rig.evaluate_batch(&[0.5, 0.0, 0.0, 0.25], &mut out).unwrap_err().to_string();
    assert!(err.contains("it answered NaN for vertex 0 (x) of a pose (c0 = 0.5, c1 = 0, c2 = 0, c3 = 0.25)"), "{err}");
    assert!(err.contains("reprise-example-rig"), "the command is named: {err}");
}

/// An evaluator that writes text to its stdout and stays alive was reported as "no answer
/// within 60 s"; it is refused at once, quoting what it wrote.
#[cfg(unix)]
#[test]
fn evaluator_writing_text_is_named_at_once() {
    let start = std::time::Instant::now();
    let command: Vec<String> = ["sh", "-c", "echo loading the rig...; sleep 30"].map(String::from).to_vec();
    let err =
        ExternalRig::spawn_with_timeout(&command, Path::new("."), names(2), vec![0.0; 2], Duration::from_secs(20))
            .err()
            .unwrap()
            .to_string();
    assert!(err.contains("its output is not an Arrow IPC stream: it starts with `loading `"), "{err}");
    assert!(err.contains("logs go to stderr"), "{err}");
    assert!(start.elapsed() < Duration::from_secs(10), "not after the time-out: {:?}", start.elapsed());
}

#[test]
fn evaluator_that_cannot_start() {
    let err = ExternalRig::spawn(&["/nonexistent/rig".into()], Path::new("."), names(2), vec![0.0; 2])
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("/nonexistent/rig") && err.contains("cannot start"), "{err}");
}
