//! Prints what `reprise-gltf` makes of a glTF file and measures rig evaluation speed.
//! Usage: `cargo run --release -p reprise-gltf --example gltf_info -- FILE [FPS]`

use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(args.next().ok_or("usage: gltf_info FILE [FPS]")?);
    let fps: f64 = args.next().map_or(Ok(24.0), |s| s.parse())?;
    let curves = reprise_gltf::ingest(&path, fps)?;
    println!("{} controls, {} clips at {fps} fps", curves.controls.len(), curves.clips.len());
    for c in &curves.controls {
        println!(
            "  {:<28} {:<7} {:<6} default {:>8.4} range [{:>9.4}, {:>9.4}]",
            c.name, c.group, c.unit, c.default, c.min, c.max
        );
    }
    for clip in &curves.clips {
        println!("  clip {:<26} {:>4} frames, source {:.2} fps", clip.name, clip.frames, clip.source_fps);
    }
    match reprise_gltf::GltfRig::open(&path) {
        Ok(rig) => {
            let controls = rig.default_controls();
            let mut out = vec![0.0; 3 * rig.vertex_count()];
            let n = 2000;
            let t0 = Instant::now();
            for _ in 0..n {
                rig.evaluate(&controls, &mut out);
            }
            let dt = t0.elapsed().as_secs_f64();
            println!(
                "rig: {} vertices, {} triangles, {:.0} evaluations/second (one thread)",
                rig.vertex_count(),
                rig.triangles().len(),
                n as f64 / dt
            );
        }
        Err(e) => println!("rig: {e}"),
    }
    Ok(())
}
