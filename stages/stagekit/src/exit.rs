//! The exit codes of every reprise binary, in one place. The runner and CI branch on
//! these codes, never on message text.

/// The stage finished and wrote all its outputs.
pub const OK: i32 = 0;
/// The stage failed for a reason not covered below (an internal error).
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
