//! `reprise-export-gltf`: see `reprise_export_gltf` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_export_gltf::Args::parse();
    reprise_stagekit::main("reprise-export-gltf", reprise_stagekit::code_id!("REPRISE_CODE_ID_EXPORT_GLTF"), || {
        if let Some(clips) = reprise_export_gltf::run(&args)? {
            for (name, frames) in &clips {
                eprintln!("exported animation `{name}` ({frames} frames) into {}", args.io.glb.display());
            }
        }
        Ok(())
    });
}
