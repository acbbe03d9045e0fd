//! `reprise`: the pipeline runner. Its logic lives in `reprise-runner`; this binary tells
//! it what each reprise stage reads and writes ([`reprise::STAGES`]), so pipelines can
//! leave the wiring out, gives it `reprise init` (`reprise-init`), and tells it what
//! `reprise replay` runs (`reprise-replay`'s declaration).

fn main() {
    let commands = reprise_runner::Commands {
        known: reprise::STAGES,
        init: Some(reprise_init::init),
        replay: Some(&reprise_replay::WIRING),
    };
    std::process::exit(reprise_runner::main_with_args(std::env::args_os(), commands));
}
