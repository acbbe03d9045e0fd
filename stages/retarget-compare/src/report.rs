//! Protocol A's Markdown report: the setting, the table (mean ± sd over draws), each
//! method against GPR, and the bar stated with the numbers that decide it.

use std::fmt::Write as _;

use reprise_retarget::protocol::{Config, Method};

use crate::Summary;

/// The paper's method, whose ratio to GPR the bar reads.
pub const PAPERS: Method = Method::SemiSupervisedLle;

/// The bar: the paper's method at most this × GPR's RMS at up to [`BAR_LABELS`] labels.
pub const BAR_RATIO: f64 = 0.8;
/// The largest label count the bar applies to.
pub const BAR_LABELS: i64 = 10;

/// The report; `chart` is the chart's file name beside it.
pub fn markdown(s: &Summary, cfg: &Config, markers: usize, chart: &str) -> String {
    let mut md = String::new();
    let (train, test) = &s.blocks;
    let _ = writeln!(md, "# Retargeting, protocol A: error against labelled pairs\n");
    let _ = writeln!(
        md,
        "A capture of {markers} markers (σc = {:.3e} capture units) with known targets ({} dimensions). \
         Frames {}–{} train, frames {}–{} are mapped in order (each from the previous one); the {} frames between \
         are left out, being near copies of their neighbours. Each label count is drawn {} times: the labelled \
         frames and {} unlabelled frames of each space, at random from the training block. The GPLVM variants use \
         q = {}, k = {}, the {} start and at most {} L-BFGS iterations. The error is the RMS over the mapped frames \
         and the target dimensions, in target units.\n",
        cfg.capture_noise,
        s.targets,
        train.start,
        train.end.saturating_sub(1),
        test.start,
        test.end.saturating_sub(1),
        test.start - train.end,
        cfg.draws,
        cfg.unlabelled,
        cfg.q,
        cfg.k,
        match cfg.init {
            reprise_retarget::model::Init::Alignment => "manifold-alignment (Ham et al.)",
            reprise_retarget::model::Init::Pca => "PCA",
        },
        cfg.max_iters,
    );
    let _ = writeln!(md, "![RMS against labelled pairs]({chart})\n");
    let mut labels: Vec<i64> = s.rows.iter().map(|r| r.labels).collect();
    labels.dedup();
    let rms = |m: &str, l: i64| s.rows.iter().find(|r| r.method == m && r.labels == l);
    let _ = write!(md, "| method |");
    for l in &labels {
        let _ = write!(md, " {l} labels |");
    }
    let _ = writeln!(md, "\n|---|{}", "---|".repeat(labels.len()));
    for m in Method::ALL {
        let _ = write!(md, "| {} |", m.name());
        for &l in &labels {
            let gpr = rms(Method::Gpr.name(), l).map(|r| r.rms);
            let _ = match (rms(m.name(), l), gpr) {
                (Some(r), Some(g)) if m != Method::Gpr && g > 0.0 => {
                    write!(md, " {:.4} ± {:.4} ({:.2} × GPR) |", r.rms, r.sd, r.rms / g)
                }
                (Some(r), _) => write!(md, " {:.4} ± {:.4} |", r.rms, r.sd),
                (None, _) => write!(md, " – |"),
            };
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md);
    for &l in labels.iter().filter(|&&l| l <= BAR_LABELS) {
        if let (Some(p), Some(g)) = (rms(PAPERS.name(), l), rms(Method::Gpr.name(), l)) {
            let ratio = p.rms / g.rms;
            let _ = writeln!(
                md,
                "- {l} labels: the paper's method is at {ratio:.2} × GPR's RMS; the bar is ≤ {BAR_RATIO} × — {}.",
                if ratio <= BAR_RATIO { "met" } else { "**not met**" }
            );
        }
    }
    let _ = writeln!(
        md,
        "\nWith {} draws the spread between draws (± sd) is of the order of the differences between methods; \
         read a difference as real only where it exceeds it.",
        cfg.draws
    );
    md
}
