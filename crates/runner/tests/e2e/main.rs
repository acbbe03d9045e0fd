//! End-to-end tests of the runner: `main_with_args`/`main_with_io` driving real child
//! processes, tiny shell-script stages written to a tempdir per test (see `project.rs`).

#![cfg(unix)]

mod cache;
mod commands;
mod failures;
mod multi_input;
mod project;
mod selection;
