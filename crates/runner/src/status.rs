//! `reprise status`: every stage, fresh or stale, with every reason it is stale — including
//! stages that are stale only because something upstream will rerun.

use std::collections::BTreeSet;
use std::io::Write;

use crate::cache;
use crate::error::Result;
use crate::hash::FileHasher;
use crate::locate::BinDirs;
use crate::lock::LockFile;
use crate::pipeline::Pipeline;

/// Prints the status of every stage (in run order) to `out`, warnings to `log`.
pub fn status(pipeline_file: &std::path::Path, dirs: &BinDirs, out: &mut dyn Write, log: &mut dyn Write) -> Result<()> {
    let (pipeline, dag) = crate::load(pipeline_file, dirs.known)?;
    let (lock, warning) = LockFile::load(&pipeline.lock_path(), &pipeline.name);
    if let Some(warning) = warning {
        let _ = writeln!(log, "reprise: warning: {warning}");
    }
    let forced = BTreeSet::new();
    let ctx = cache::Inputs { pipeline: &pipeline, dag: &dag, lock: &lock, forced: &forced, dirs };
    let plan = cache::assess(&ctx, &mut FileHasher::new())?;
    let _ = out.write_all(render(&pipeline, dag.order(), &plan).as_bytes());
    let _ = out.write_all(jobs(&pipeline).as_bytes());
    Ok(())
}

/// The Slurm jobs a run has in flight (or a killed run left), from the jobs file; one
/// line each (`status` and `dag` print them).
pub(crate) fn jobs(pipeline: &Pipeline) -> String {
    let listed = crate::slurm::listed_jobs(pipeline);
    if listed.is_empty() {
        return String::new();
    }
    match crate::slurm::in_flight(&listed) {
        None => format!(
            "{} Slurm job(s) listed in {}, but `squeue` cannot be asked about them\n",
            listed.len(),
            crate::slurm::jobs_file(pipeline).display()
        ),
        Some(live) if live.is_empty() => String::new(),
        Some(live) => live
            .iter()
            .map(|(job, states)| {
                format!("Slurm job {} in flight: stage `{}`, {} task(s): {states}\n", job.job, job.stage, job.tasks)
            })
            .collect(),
    }
}

fn render(pipeline: &Pipeline, order: &[usize], plan: &[cache::Assessment]) -> String {
    use std::fmt::Write as _;
    let mut text = String::new();
    let _ = writeln!(text, "pipeline `{}` ({})", pipeline.name, pipeline.file);
    let width = pipeline.stages.iter().map(|s| s.name.len()).max().unwrap_or(0);
    for &i in order {
        let verdict = if plan[i].is_fresh() { "fresh" } else { "stale" };
        let _ = writeln!(text, "  {:<width$}  {verdict}", pipeline.stages[i].name);
        for reason in &plan[i].reasons {
            let _ = writeln!(text, "  {:<width$}    - {reason}", "");
        }
    }
    let stale = plan.iter().filter(|a| !a.is_fresh()).count();
    let _ = writeln!(text, "{} stages: {} fresh, {stale} stale", plan.len(), plan.len() - stale);
    text
}
