//! A panic is a bug in reprise, never the user's fault: it must not reach the user as a
//! Rust backtrace. [`install`] replaces the panic hook with one that prints one clean
//! line — `<binary>: internal error: <message> (at <file:line>)` and where to report it —
//! and [`crate::main`] turns the unwound panic into exit code [`crate::exit::FAILURE`].
//! `RUST_BACKTRACE=1` adds the backtrace for whoever debugs it.

use std::backtrace::{Backtrace, BacktraceStatus};
use std::panic::PanicHookInfo;

/// Installs the clean panic hook for `binary` (process-wide).
pub fn install(binary: &str) {
    let binary = binary.to_string();
    std::panic::set_hook(Box::new(move |info| {
        if reprise_artifact::contain::is_contained() {
            return; // a dependency's panic on bad input, turned into an error by the caller
        }
        crate::say_whole(&format!("{}\n", message(&binary, info)));
        let backtrace = Backtrace::capture();
        if backtrace.status() == BacktraceStatus::Captured {
            eprintln!("{backtrace}");
        }
    }));
}

/// The line printed for a panic.
fn message(binary: &str, info: &PanicHookInfo<'_>) -> String {
    let payload = info
        .payload()
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| info.payload().downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into());
    let place = info.location().map(|l| format!(" (at {}:{})", l.file(), l.line())).unwrap_or_default();
    format!(
        "{binary}: internal error: {payload}{place}\n{binary}: this is a bug in reprise, not in your data or \
         settings; please report it with the command, pipeline.toml and input that caused it \
         (RUST_BACKTRACE=1 adds a backtrace)"
    )
}
