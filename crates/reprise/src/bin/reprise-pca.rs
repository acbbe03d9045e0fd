//! `reprise-pca`: see `reprise_pca` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_pca::Args::parse();
    reprise_stagekit::main("reprise-pca", reprise_stagekit::code_id!("REPRISE_CODE_ID_PCA"), || {
        if let Some(s) = reprise_pca::run(&args)? {
            eprint!("{s}");
        }
        Ok(())
    });
}
