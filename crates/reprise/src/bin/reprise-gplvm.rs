//! `reprise-gplvm`: see `reprise_gplvm` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_gplvm::Args::parse();
    reprise_stagekit::main("reprise-gplvm", reprise_stagekit::code_id!("REPRISE_CODE_ID_GPLVM"), || {
        if let Some(fits) = reprise_gplvm::run(&args)? {
            eprint!("{}", reprise_gplvm::summary::Fits(&fits));
        }
        Ok(())
    });
}
