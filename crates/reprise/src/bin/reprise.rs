//! `reprise`: the pipeline runner. All logic lives in `reprise-runner`; this binary tells
//! it what each reprise stage reads and writes ([`reprise::STAGES`]), so pipelines can
//! leave the wiring out.

fn main() {
    std::process::exit(reprise_runner::main_with_stages(std::env::args_os(), reprise::STAGES));
}
