//! `reprise`: the pipeline runner. All logic lives in `reprise-runner`.
fn main() {
    std::process::exit(reprise_runner::main_with_args(std::env::args_os()));
}
