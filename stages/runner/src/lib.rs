//! The `reprise` runner (being written).
use std::ffi::OsString;

/// Entry point of the `reprise` binary; returns the process exit code.
pub fn main_with_args(_args: impl IntoIterator<Item = OsString>) -> i32 {
    eprintln!("reprise: the runner is not built yet");
    reprise_stagekit::exit::FAILURE
}
