//! The exit codes of every reprise binary, in one place. The runner and CI branch on
//! these codes, never on message text.

/// The stage finished and wrote all its outputs.
pub const OK: i32 = 0;
/// An internal error: a bug in reprise (a panic is reported as one, with where to report
/// it), or a failure not covered below.
pub const FAILURE: i32 = 1;
/// Usage or configuration error: a bad flag, an unknown or invalid parameter, a bad
/// `pipeline.toml` (unknown key, unknown stage, dependency cycle).
pub const CONFIG: i32 = 2;
/// Bad input data: a missing file, a wrong schema version, an unknown, missing or
/// duplicated column, a non-finite value, inconsistent frames or labels.
pub const INPUT: i32 = 3;
/// Numerical failure: no convergence, a matrix that is not positive definite.
pub const NUMERICAL: i32 = 4;
/// A child stage died from a signal or could not be started (runner only).
pub const STAGE_CRASHED: i32 = 5;
/// The environment refused: permission denied, a read-only or full file system — the
/// data and settings may be fine, the machine is not.
pub const ENVIRONMENT: i32 = 6;
/// `reprise run` was interrupted (SIGINT, SIGTERM or SIGHUP) and stopped its stage; the
/// shell convention 128 + signal number is used instead (130 for Ctrl-C).
pub const INTERRUPTED_BASE: i32 = 128;

/// Whether an I/O error is the machine's doing ([`ENVIRONMENT`]) rather than the data's.
pub fn is_environment(e: &std::io::Error) -> bool {
    use std::io::ErrorKind as K;
    matches!(e.kind(), K::PermissionDenied | K::ReadOnlyFilesystem | K::StorageFull | K::QuotaExceeded | K::OutOfMemory)
}
