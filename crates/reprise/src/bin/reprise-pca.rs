//! `reprise-pca`: see `reprise_pca` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_pca::Args::parse();
    reprise_stagekit::main("reprise-pca", reprise_stagekit::code_id!("REPRISE_CODE_ID_PCA"), || {
        if let Some(s) = reprise_pca::run(&args)? {
            eprintln!(
                "{:<14} {:>6} {:>8} {:>3} {:>9} {:>10}",
                "label", "frames", "controls", "d", "explained", "d unscaled"
            );
            for l in &s.labels {
                eprintln!(
                    "{:<14} {:>6} {:>8} {:>3} {:>9.3} {:>10}",
                    l.label, l.frames, l.controls, l.d, l.explained, l.d_unscaled
                );
            }
            eprintln!("mesh RMS error (scaled / unscaled) at the same d:");
            for l in &s.labels {
                let at = |variant: &str, d: i64| {
                    s.errors
                        .iter()
                        .find(|e| e.label == l.label && e.variant == variant && e.d == d)
                        .and_then(|e| e.mesh_rmse)
                };
                let cells: Vec<String> = [3, 10, l.d as i64]
                    .iter()
                    .map(|&d| match (at("scaled", d), at("unscaled", d)) {
                        (Some(a), Some(b)) => format!("d={d}: {a:.4} / {b:.4}"),
                        _ => format!("d={d}: -"),
                    })
                    .collect();
                eprintln!("  {:<12} {}", l.label, cells.join("   "));
            }
        }
        Ok(())
    });
}
