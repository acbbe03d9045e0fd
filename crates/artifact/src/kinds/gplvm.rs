//! The gplvm stage's artifacts: latent points, models, optimisation traces, fit summaries.
//!
//! `gplvm_latents` — one row per training frame, in each model's point order:
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `label` | Utf8 | the model |
//! | `segment_id`, `clip`, `frame` | Int64, Utf8, Int64 | the frame |
//! | `time` | Float64 | seconds from the segment's start (the dynamics prior's input) |
//! | `x0`, `x1`, … | Float64 | latent coordinates |
//!
//! `gplvm_models` — what reconstruction needs, self-contained. Per label, rows by `role`:
//! one `offset` row holding the output offset $\bar y$ in `a0…` (latents null); one
//! `latent` row per training frame (`point` = 0, 1, …, in the order of `gplvm_latents`)
//! with its latent in `x0…`; and the mean map's *support points*, which carry their row of
//! weights in `a0…` (null beyond the label's PCA dimension). A dense fit's support points
//! are its training latents: each `latent` row carries its row of $A = K^{-1}(Y - \bar y)$.
//! A sparse fit's are its inducing points: `inducing` rows (`point` = 0, 1, …, $M - 1$)
//! with $u$ in `x0…` and its row of $W = A^{-1}K_{uf}(Y - \bar y)$ in `a0…`, and its
//! `latent` rows have `a0…` null. The columns `rbf_variance`, `lengthscale`,
//! `white_variance` (optimised $\sigma_f^2, \ell, \sigma_w^2$), `white_variance_used` (after
//! the floor) and `jitter` (added to the diagonal of $K$, or of $K_{uu}$) repeat on every
//! row of a label. The mean map is $\mu(x) = \bar y + A^\top k(x)$ with
//! $k_i(x) = \sigma_f^2e^{-\lVert x-s_i\rVert^2/(2\ell^2)}$ over the support points $s_i$.
//!
//! `gplvm_trace` — per label and optimiser iteration: `label`, `iteration` (1, 2, …),
//! `value` (objective $E$ at the current point), `grad_norm` ($\lVert\nabla E\rVert_2$),
//! `beta` (SCG's scale; L-BFGS's accepted step length), `accepted`, `evaluations`
//! (cumulative) and `seconds` (since the optimiser started).
//!
//! `gplvm_fits` — one row per label ([`FitSummary`], written by [`write_fits`], read by
//! [`read_fits`]):
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `label` | Utf8 | the model |
//! | `frames`, `d`, `q` | Int64 | training frames $N$, PCA dimension $d$, latent dimension $q$ |
//! | `inducing_points` | Int64 | $M$ of a sparse (DTC) fit; 0 for the dense fit (the stage's per-label rule chose) |
//! | `optimizer`, `connectivity_path` | Utf8 | `lbfgs`/`scg`; how the connectivity prior entered (`exact`, `staged`, `subset`, `sampled`, `coarse`) |
//! | `stage_iterations` | Utf8 | iterations per stage, `"i"` or `"subset+exact"` |
//! | `iterations`, `evaluations` | Int64 | optimiser iterations; objective evaluations |
//! | `initial_objective`, `objective` | Float64 | $E$ at the start and at the optimum |
//! | `neg_log_likelihood`, `dynamics`, `connectivity`, `signal` | Float64 | the terms of $E$ at the optimum |
//! | `connectivity_exact` | Float64, nullable | the exact connectivity prior at the optimum (null above 2,000 frames on the paths that do not minimise it: it would cost more than the fit) |
//! | `grad_norm`, `rel_decrease`, `rel_gradient` | Float64 | $\lVert\nabla E\rVert_2$; the convergence rule's two measures (`rel_decrease` may be `inf`) |
//! | `jitter`, `dynamics_jitter` | Float64 | jitter added to $K$ and to the dynamics prior's blocks |
//! | `converged`, `stop_reason` | Boolean, Utf8 | whether a convergence test stopped the fit, and why it stopped |
//! | `seconds` | Float64 | wall-clock seconds of the fit |
//! | `heldout_gplvm_mesh_rmse` | Float64, nullable | held-out check (null when off): RMS vertex distance, mesh units, of the held-out frames through their best latent point of a GPLVM fitted without them, in a PCA basis fitted without them |
//! | `heldout_pca_q_mesh_rmse`, `heldout_pca_d_mesh_rmse` | Float64, nullable | the same frames through that basis's first $q$ and all `heldout_d` components |
//! | `heldout_d` | Int64 | the dimension of that basis: $d$, or fewer if the training frames span fewer (0 when off) |
//! | `heldout_frames` | Int64 | held-out frames (0 when off) |
//! | `generative_gplvm_mesh_rmse` | Float64, nullable | held-out frames whose previous and next frames are training frames, through the GPLVM at the midpoint of the neighbours' latents (null without such frames) |
//! | `generative_interp_mesh_rmse` | Float64, nullable | the same frames as the midpoint of the neighbours' poses (linear interpolation of controls) |
//! | `generative_interp_d_mesh_rmse` | Float64, nullable | the same frames as the midpoint of the neighbours' coordinates in the check's PCA basis: interpolation confined to the space the GPLVM models (its floor is PCA-d's, like the GPLVM's) |
//! | `generative_frames` | Int64 | frames of the generative check (0 when off or none) |

use std::path::Path;

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the latents table.
pub const GPLVM_LATENTS: Kind = Kind { name: "gplvm_latents", version: 1 };
/// Kind of the models table.
pub const GPLVM_MODELS: Kind = Kind { name: "gplvm_models", version: 2 };
/// Kind of the trace table.
pub const GPLVM_TRACE: Kind = Kind { name: "gplvm_trace", version: 2 };
/// Kind of the fit summary table.
pub const GPLVM_FITS: Kind = Kind { name: "gplvm_fits", version: 4 };

/// Per-frame latent points of every model.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Latents {
    /// Label per row.
    pub label: Vec<String>,
    /// Segment per row.
    pub segment_id: Vec<i64>,
    /// Clip per row.
    pub clip: Vec<String>,
    /// Frame per row.
    pub frame: Vec<i64>,
    /// Seconds from the segment's start.
    pub time: Vec<f64>,
    /// Latent point per row (all of length q).
    pub x: Vec<Vec<f64>>,
}

/// Numbered columns `prefix0, prefix1, …` while they exist.
fn numbered(t: &Table, prefix: &str) -> Vec<String> {
    (0..).map(|k| format!("{prefix}{k}")).take_while(|n| t.has_column(n)).collect()
}

/// Writes the latents atomically.
pub fn write_latents(path: &Path, l: &Latents, provenance: &Provenance) -> Result<()> {
    let q = l.x.first().map_or(0, Vec::len);
    let mut cols = Columns::new()
        .str("label", &l.label)
        .i64("segment_id", l.segment_id.clone())
        .str("clip", &l.clip)
        .i64("frame", l.frame.clone())
        .f64("time", l.time.clone());
    for k in 0..q {
        cols = cols.f64(&format!("x{k}"), l.x.iter().map(|x| x[k]).collect());
    }
    crate::table::write(path, GPLVM_LATENTS, cols, provenance, &[])
}

/// Reads the latents.
pub fn read_latents(path: &Path) -> Result<Latents> {
    let t = Table::read(path, GPLVM_LATENTS)?;
    let xs = numbered(&t, "x").iter().map(|n| t.f64(n)).collect::<Result<Vec<_>>>()?;
    if xs.is_empty() {
        return Err(t.invalid("no latent columns x0, x1, …"));
    }
    Ok(Latents {
        label: t.strings("label")?,
        segment_id: t.i64("segment_id")?.to_vec(),
        clip: t.strings("clip")?,
        frame: t.i64("frame")?.to_vec(),
        time: t.f64("time")?.to_vec(),
        x: (0..t.rows()).map(|r| xs.iter().map(|c| c[r]).collect()).collect(),
    })
}

/// One label's model, as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct GplvmModel {
    /// Label.
    pub label: String,
    /// Latent dimension q.
    pub q: usize,
    /// Output (PCA) dimension d.
    pub d: usize,
    /// $\sigma_f^2$.
    pub rbf_variance: f64,
    /// $\ell$.
    pub lengthscale: f64,
    /// $\sigma_w^2$ as optimised.
    pub white_variance: f64,
    /// $\sigma_w^2$ after the floor.
    pub white_variance_used: f64,
    /// Jitter added to the diagonal of $K$ beyond $\sigma_w^2$.
    pub jitter: f64,
    /// Training latents, row-major `N × q`.
    pub x: Vec<f64>,
    /// A sparse fit's inducing points, row-major `M × q` (empty for a dense fit).
    pub inducing: Vec<f64>,
    /// The support points' weights: $K^{-1}(Y - \bar y)$ (row-major `N × d`) for a dense
    /// fit, $W = A^{-1}K_{uf}(Y - \bar y)$ (row-major `M × d`) for a sparse one.
    pub kinv_y: Vec<f64>,
    /// $\bar y$ (length d).
    pub offset: Vec<f64>,
}

impl GplvmModel {
    /// Training points N.
    pub fn n(&self) -> usize {
        self.x.len() / self.q.max(1)
    }

    /// Inducing points M (0 for a dense fit).
    pub fn m(&self) -> usize {
        self.inducing.len() / self.q.max(1)
    }

    /// Whether the model is a sparse fit's (its support points are inducing points).
    pub fn is_sparse(&self) -> bool {
        !self.inducing.is_empty()
    }
}

/// The `role` of a `gplvm_models` row.
const OFFSET: &str = "offset";
const LATENT: &str = "latent";
const INDUCING: &str = "inducing";

/// Writes the models atomically (all with the same q).
pub fn write_models(path: &Path, models: &[GplvmModel], provenance: &Provenance) -> Result<()> {
    let q = models.first().map_or(0, |m| m.q);
    let dmax = models.iter().map(|m| m.d).max().unwrap_or(0);
    let (mut label, mut role, mut point) = (Vec::new(), Vec::new(), Vec::new());
    let (mut s2, mut ell, mut w, mut wu, mut jit) = (vec![], vec![], vec![], vec![], vec![]);
    let mut xs: Vec<Vec<Option<f64>>> = vec![Vec::new(); q];
    let mut as_: Vec<Vec<Option<f64>>> = vec![Vec::new(); dmax];
    for m in models {
        // The support points' weights: the latents' (dense) or the inducing points' (sparse).
        let weights = |i: usize| m.kinv_y.get(i * m.d..(i + 1) * m.d);
        let latent_weights = |i: usize| if m.is_sparse() { None } else { weights(i) };
        let latent_rows = (0..m.n()).map(|i| (LATENT, i, Some(&m.x[i * m.q..(i + 1) * m.q]), latent_weights(i)));
        let inducing_rows = (0..m.m()).map(|i| (INDUCING, i, Some(&m.inducing[i * m.q..(i + 1) * m.q]), weights(i)));
        let rows =
            std::iter::once((OFFSET, 0, None, Some(m.offset.as_slice()))).chain(latent_rows).chain(inducing_rows);
        for (r, i, xrow, arow) in rows {
            label.push(m.label.as_str());
            role.push(r);
            point.push(if r == OFFSET { -1 } else { i as i64 });
            s2.push(m.rbf_variance);
            ell.push(m.lengthscale);
            w.push(m.white_variance);
            wu.push(m.white_variance_used);
            jit.push(m.jitter);
            xs.iter_mut().enumerate().for_each(|(k, c)| c.push(xrow.map(|r| r[k])));
            as_.iter_mut().enumerate().for_each(|(k, c)| c.push(arow.and_then(|a| a.get(k).copied())));
        }
    }
    let mut cols = Columns::new()
        .str("label", &label)
        .str("role", &role)
        .i64("point", point)
        .f64("rbf_variance", s2)
        .f64("lengthscale", ell)
        .f64("white_variance", w)
        .f64("white_variance_used", wu)
        .f64("jitter", jit);
    for (k, c) in xs.into_iter().enumerate() {
        cols = cols.f64_opt(&format!("x{k}"), c);
    }
    for (k, c) in as_.into_iter().enumerate() {
        cols = cols.f64_opt(&format!("a{k}"), c);
    }
    crate::table::write(path, GPLVM_MODELS, cols, provenance, &[])
}

/// Reads the models, checking that each label starts with its offset row, numbers its
/// latent and inducing points 0, 1, … without gaps, and gives weights to exactly its
/// support points (every latent of a dense model, every inducing point of a sparse one).
pub fn read_models(path: &Path) -> Result<Vec<GplvmModel>> {
    let t = Table::read(path, GPLVM_MODELS)?;
    let (label, role, point) = (t.str("label")?, t.str("role")?, t.i64("point")?);
    let (s2, ell, w) = (t.f64("rbf_variance")?, t.f64("lengthscale")?, t.f64("white_variance")?);
    let (wu, jit) = (t.f64("white_variance_used")?, t.f64("jitter")?);
    let xs = numbered(&t, "x").iter().map(|n| t.f64_opt(n)).collect::<Result<Vec<_>>>()?;
    let as_ = numbered(&t, "a").iter().map(|n| t.f64_opt(n)).collect::<Result<Vec<_>>>()?;
    let mut models: Vec<GplvmModel> = Vec::new();
    for r in 0..t.rows() {
        let arow: Vec<f64> = as_.iter().map_while(|c| c[r]).collect();
        if role[r] == OFFSET {
            models.push(GplvmModel {
                label: label[r].into(),
                q: xs.len(),
                d: arow.len(),
                rbf_variance: s2[r],
                lengthscale: ell[r],
                white_variance: w[r],
                white_variance_used: wu[r],
                jitter: jit[r],
                x: vec![],
                inducing: vec![],
                kinv_y: vec![],
                offset: arow,
            });
            continue;
        }
        let m = models.last_mut().filter(|m| m.label == label[r]).ok_or_else(|| {
            t.invalid(format!("row {r}: a `{}` row of `{}` before its offset row", role[r], label[r]))
        })?;
        let (q, list) = (
            m.q.max(1),
            match role[r] {
                LATENT => &mut m.x,
                INDUCING => &mut m.inducing,
                other => {
                    return Err(t.invalid(format!("row {r}: role `{other}`; expected offset, latent or inducing")));
                }
            },
        );
        let next = list.len() / q;
        if point[r] != next as i64 {
            return Err(t.invalid(format!("row {r}: {} point {} of `{}` out of order", role[r], point[r], label[r])));
        }
        let xrow: Vec<f64> = xs.iter().map_while(|c| c[r]).collect();
        if xrow.len() != m.q || !(arow.is_empty() || arow.len() == m.d) {
            return Err(t.invalid(format!(
                "row {r}: {} latent and {} output values, expected {} and {} (label `{}`)",
                xrow.len(),
                arow.len(),
                m.q,
                m.d,
                m.label
            )));
        }
        list.extend(xrow);
        m.kinv_y.extend(arow);
    }
    for m in &models {
        let support = if m.is_sparse() { m.m() } else { m.n() };
        if m.n() == 0 {
            return Err(t.invalid(format!("label `{}` has no training points", m.label)));
        }
        if m.kinv_y.len() != support * m.d {
            let what = if m.is_sparse() { "its inducing points and none of its latents" } else { "every latent" };
            return Err(t.invalid(format!("label `{}`: weights `a0…` must be on {what}", m.label)));
        }
    }
    Ok(models)
}

/// The optimisation traces of every label.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Label per row.
    pub label: Vec<String>,
    /// Iteration, from 1.
    pub iteration: Vec<i64>,
    /// Objective at the current point.
    pub value: Vec<f64>,
    /// Gradient norm there.
    pub grad_norm: Vec<f64>,
    /// SCG's β after the iteration (L-BFGS: the step length).
    pub beta: Vec<f64>,
    /// Whether the iteration's step was accepted.
    pub accepted: Vec<bool>,
    /// Evaluations so far.
    pub evaluations: Vec<i64>,
    /// Seconds since the optimiser started.
    pub seconds: Vec<f64>,
}

/// Writes the traces atomically.
pub fn write_trace(path: &Path, t: &Trace, provenance: &Provenance) -> Result<()> {
    let cols = Columns::new()
        .str("label", &t.label)
        .i64("iteration", t.iteration.clone())
        .f64("value", t.value.clone())
        .f64_any("grad_norm", t.grad_norm.clone())
        .f64_any("beta", t.beta.clone())
        .bool("accepted", t.accepted.clone())
        .i64("evaluations", t.evaluations.clone())
        .f64("seconds", t.seconds.clone());
    crate::table::write(path, GPLVM_TRACE, cols, provenance, &[])
}

/// Reads the traces as [`write_trace`] wrote them (β may be infinite: read as it is).
pub fn read_trace(path: &Path) -> Result<Trace> {
    let t = Table::read(path, GPLVM_TRACE)?;
    Ok(Trace {
        label: t.strings("label")?,
        iteration: t.i64("iteration")?.to_vec(),
        value: t.f64("value")?.to_vec(),
        grad_norm: t.f64_any("grad_norm")?.to_vec(),
        beta: t.f64_any("beta")?.to_vec(),
        accepted: t.bool("accepted")?,
        evaluations: t.i64("evaluations")?.to_vec(),
        seconds: t.f64("seconds")?.to_vec(),
    })
}

/// One label's fit summary (a row of `gplvm_fits`).
#[derive(Debug, Clone, PartialEq)]
pub struct FitSummary {
    /// Label.
    pub label: String,
    /// Training frames N.
    pub frames: i64,
    /// Output (PCA) dimension d.
    pub d: i64,
    /// Latent dimension q.
    pub q: i64,
    /// Inducing points M of a sparse fit; 0 for a dense one.
    pub inducing_points: i64,
    /// The optimiser (`lbfgs`, `scg`).
    pub optimizer: String,
    /// How the connectivity prior entered the fit (`exact`, `staged`, `subset`, `sampled`, `coarse`).
    pub connectivity_path: String,
    /// Iterations per stage of the fit (one entry, or the subset stage then the exact one),
    /// written as `stage_iterations` = "i1+i2".
    pub stage_iterations: Vec<i64>,
    /// Optimiser iterations.
    pub iterations: i64,
    /// Objective evaluations (value and gradient together).
    pub evaluations: i64,
    /// Objective $E$ at the start.
    pub initial_objective: f64,
    /// The objective $E$ the optimiser minimised, at the optimum: the sum of the next four.
    pub objective: f64,
    /// $-\log p(Y\mid X)$ at the optimum.
    pub neg_log_likelihood: f64,
    /// $-\psi_D$ at the optimum (0 without the prior).
    pub dynamics: f64,
    /// $-\psi_C$ at the optimum as the fit computed it (the path's prior; 0 without it).
    pub connectivity: f64,
    /// $E_S$, the signal prior on $\sigma_f^2$, at the optimum (0 without it).
    pub signal: f64,
    /// The exact connectivity prior at the optimum (= `connectivity` on the `exact` and
    /// `staged` paths; the reference for the cheaper ones; `None` where it was not
    /// evaluated, film-scale labels).
    pub connectivity_exact: Option<f64>,
    /// $\lVert\nabla E\rVert_2$ at the optimum.
    pub grad_norm: f64,
    /// The convergence rule's mean relative decrease of $E$ per iteration over its
    /// window, at the optimum (`inf` if the window never filled).
    pub rel_decrease: f64,
    /// The convergence rule's scaled gradient at the optimum.
    pub rel_gradient: f64,
    /// Jitter added to the diagonal of $K$.
    pub jitter: f64,
    /// Jitter the dynamics prior's blocks needed (0 without the prior).
    pub dynamics_jitter: f64,
    /// Whether a convergence test stopped the optimiser (never true at the iteration cap).
    pub converged: bool,
    /// Why it stopped: `converged` (the window rule), `tolerance` (Netlab's step test),
    /// `gradient`, `tiny-direction`, or, not converged, `max-iterations`, `stalled`.
    pub stop_reason: String,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
    /// Held-out check (None when off; the gplvm stage's `heldout` module): every K-th
    /// frame is held out and the rest fit a PCA basis of `heldout_d` components and a
    /// GPLVM in it. RMS vertex distance (mesh units) of the held-out frames to their
    /// meshes through their best latent point …
    pub heldout_gplvm_mesh_rmse: Option<f64>,
    /// … through the first q components of that basis …
    pub heldout_pca_q_mesh_rmse: Option<f64>,
    /// … and through all `heldout_d` of them (the space the GPLVM models).
    pub heldout_pca_d_mesh_rmse: Option<f64>,
    /// Components of the held-out check's basis: `d`, or fewer when the training frames
    /// span fewer (0 when off).
    pub heldout_d: i64,
    /// Held-out frames (0 when off).
    pub heldout_frames: i64,
    /// Generative check (None when off or without such frames): RMS vertex distance of the
    /// held-out frames whose previous and next frames (same segment) are training frames,
    /// through the GPLVM at the midpoint of those neighbours' fitted latents …
    pub generative_gplvm_mesh_rmse: Option<f64>,
    /// … and as the midpoint of the neighbours' poses (linear interpolation of controls,
    /// no model).
    pub generative_interp_mesh_rmse: Option<f64>,
    /// … and as the midpoint of the neighbours' coordinates in the check's basis
    /// (interpolation in the space the GPLVM models, with the same PCA-d floor).
    pub generative_interp_d_mesh_rmse: Option<f64>,
    /// Frames of the generative check.
    pub generative_frames: i64,
}

/// Writes the fit summaries atomically.
pub fn write_fits(path: &Path, rows: &[FitSummary], provenance: &Provenance) -> Result<()> {
    let i = |f: fn(&FitSummary) -> i64| rows.iter().map(f).collect::<Vec<_>>();
    let x = |f: fn(&FitSummary) -> f64| rows.iter().map(f).collect::<Vec<_>>();
    let o = |f: fn(&FitSummary) -> Option<f64>| rows.iter().map(f).collect::<Vec<_>>();
    let stage_iterations: Vec<String> =
        rows.iter().map(|r| r.stage_iterations.iter().map(i64::to_string).collect::<Vec<_>>().join("+")).collect();
    let stage_iterations: Vec<&str> = stage_iterations.iter().map(String::as_str).collect();
    let cols = Columns::new()
        .str("label", &rows.iter().map(|r| r.label.as_str()).collect::<Vec<_>>())
        .i64("frames", i(|r| r.frames))
        .i64("d", i(|r| r.d))
        .i64("q", i(|r| r.q))
        .i64("inducing_points", i(|r| r.inducing_points))
        .str("optimizer", &rows.iter().map(|r| r.optimizer.as_str()).collect::<Vec<_>>())
        .str("connectivity_path", &rows.iter().map(|r| r.connectivity_path.as_str()).collect::<Vec<_>>())
        .str("stage_iterations", &stage_iterations)
        .i64("iterations", i(|r| r.iterations))
        .i64("evaluations", i(|r| r.evaluations))
        .f64("initial_objective", x(|r| r.initial_objective))
        .f64("objective", x(|r| r.objective))
        .f64("neg_log_likelihood", x(|r| r.neg_log_likelihood))
        .f64("dynamics", x(|r| r.dynamics))
        .f64("connectivity", x(|r| r.connectivity))
        .f64("signal", x(|r| r.signal))
        .f64_opt("connectivity_exact", o(|r| r.connectivity_exact))
        .f64("grad_norm", x(|r| r.grad_norm))
        .f64_any("rel_decrease", x(|r| r.rel_decrease))
        .f64("rel_gradient", x(|r| r.rel_gradient))
        .f64("jitter", x(|r| r.jitter))
        .f64("dynamics_jitter", x(|r| r.dynamics_jitter))
        .bool("converged", rows.iter().map(|r| r.converged).collect())
        .str("stop_reason", &rows.iter().map(|r| r.stop_reason.as_str()).collect::<Vec<_>>())
        .f64("seconds", x(|r| r.seconds))
        .f64_opt("heldout_gplvm_mesh_rmse", o(|r| r.heldout_gplvm_mesh_rmse))
        .f64_opt("heldout_pca_q_mesh_rmse", o(|r| r.heldout_pca_q_mesh_rmse))
        .f64_opt("heldout_pca_d_mesh_rmse", o(|r| r.heldout_pca_d_mesh_rmse))
        .i64("heldout_d", i(|r| r.heldout_d))
        .i64("heldout_frames", i(|r| r.heldout_frames))
        .f64_opt("generative_gplvm_mesh_rmse", o(|r| r.generative_gplvm_mesh_rmse))
        .f64_opt("generative_interp_mesh_rmse", o(|r| r.generative_interp_mesh_rmse))
        .f64_opt("generative_interp_d_mesh_rmse", o(|r| r.generative_interp_d_mesh_rmse))
        .i64("generative_frames", i(|r| r.generative_frames));
    crate::table::write(path, GPLVM_FITS, cols, provenance, &[])
}

/// Reads the fit summaries, in file order.
pub fn read_fits(path: &Path) -> Result<Vec<FitSummary>> {
    let t = Table::read(path, GPLVM_FITS)?;
    let s = |name: &str| t.strings(name);
    let (label, optimizer, connectivity_path, stages, stop_reason) =
        (s("label")?, s("optimizer")?, s("connectivity_path")?, s("stage_iterations")?, s("stop_reason")?);
    let (frames, d, q, iterations, evaluations) =
        (t.i64("frames")?, t.i64("d")?, t.i64("q")?, t.i64("iterations")?, t.i64("evaluations")?);
    let inducing_points = t.i64("inducing_points")?;
    let (initial_objective, objective, neg_log_likelihood) =
        (t.f64("initial_objective")?, t.f64("objective")?, t.f64("neg_log_likelihood")?);
    let (dynamics, connectivity, signal, connectivity_exact) =
        (t.f64("dynamics")?, t.f64("connectivity")?, t.f64("signal")?, t.f64_opt("connectivity_exact")?);
    let (grad_norm, rel_decrease, rel_gradient) =
        (t.f64("grad_norm")?, t.f64_any("rel_decrease")?, t.f64("rel_gradient")?);
    let (jitter, dynamics_jitter, seconds, converged) =
        (t.f64("jitter")?, t.f64("dynamics_jitter")?, t.f64("seconds")?, t.bool("converged")?);
    let (held_g, held_q, held_d) = (
        t.f64_opt("heldout_gplvm_mesh_rmse")?,
        t.f64_opt("heldout_pca_q_mesh_rmse")?,
        t.f64_opt("heldout_pca_d_mesh_rmse")?,
    );
    let (heldout_d, heldout_frames) = (t.i64("heldout_d")?, t.i64("heldout_frames")?);
    let (gen_g, gen_i, gen_id, gen_frames) = (
        t.f64_opt("generative_gplvm_mesh_rmse")?,
        t.f64_opt("generative_interp_mesh_rmse")?,
        t.f64_opt("generative_interp_d_mesh_rmse")?,
        t.i64("generative_frames")?,
    );
    (0..t.rows())
        .map(|r| {
            let stage_iterations = stages[r]
                .split('+')
                .filter(|v| !v.is_empty())
                .map(str::parse)
                .collect::<std::result::Result<Vec<i64>, _>>()
                .map_err(|_| t.invalid(format!("row {r}: stage_iterations `{}` is not \"i\" or \"i+j\"", stages[r])))?;
            Ok(FitSummary {
                label: label[r].clone(),
                frames: frames[r],
                d: d[r],
                q: q[r],
                inducing_points: inducing_points[r],
                optimizer: optimizer[r].clone(),
                connectivity_path: connectivity_path[r].clone(),
                stage_iterations,
                iterations: iterations[r],
                evaluations: evaluations[r],
                initial_objective: initial_objective[r],
                objective: objective[r],
                neg_log_likelihood: neg_log_likelihood[r],
                dynamics: dynamics[r],
                connectivity: connectivity[r],
                signal: signal[r],
                connectivity_exact: connectivity_exact[r],
                grad_norm: grad_norm[r],
                rel_decrease: rel_decrease[r],
                rel_gradient: rel_gradient[r],
                jitter: jitter[r],
                dynamics_jitter: dynamics_jitter[r],
                converged: converged[r],
                stop_reason: stop_reason[r].clone(),
                seconds: seconds[r],
                heldout_gplvm_mesh_rmse: held_g[r],
                heldout_pca_q_mesh_rmse: held_q[r],
                heldout_pca_d_mesh_rmse: held_d[r],
                heldout_d: heldout_d[r],
                heldout_frames: heldout_frames[r],
                generative_gplvm_mesh_rmse: gen_g[r],
                generative_interp_mesh_rmse: gen_i[r],
                generative_interp_d_mesh_rmse: gen_id[r],
                generative_frames: gen_frames[r],
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prov() -> Provenance {
        Provenance::new("test", "0", serde_json::json!({}))
    }

    /// Traces of two labels come back as written, an infinite β included.
    #[test]
    fn traces_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let t = Trace {
            label: vec!["a".into(), "a".into(), "b".into()],
            iteration: vec![1, 2, 1],
            value: vec![3.0, 2.5, 7.0],
            grad_norm: vec![1.0, 0.5, 2.0],
            beta: vec![1e-3, f64::INFINITY, 0.5],
            accepted: vec![true, false, true],
            evaluations: vec![2, 4, 2],
            seconds: vec![0.1, 0.2, 0.1],
        };
        let path = dir.path().join("trace.parquet");
        write_trace(&path, &t, &prov()).unwrap();
        assert_eq!(read_trace(&path).unwrap(), t);
    }

    /// Dense models of different d and N, a sparse one, and latents come back as written.
    #[test]
    fn models_and_latents_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let m = |label: &str, n: usize, d: usize| GplvmModel {
            label: label.into(),
            q: 2,
            d,
            rbf_variance: 1.5,
            lengthscale: 0.7,
            white_variance: 1e-3,
            white_variance_used: 1e-3,
            jitter: 1e-8,
            x: (0..n * 2).map(|i| i as f64 * 0.1).collect(),
            inducing: vec![],
            kinv_y: (0..n * d).map(|i| i as f64 - 3.0).collect(),
            offset: (0..d).map(|i| i as f64 * 2.0).collect(),
        };
        // A sparse model: 4 latents, 2 inducing points carrying the weights.
        let sparse = GplvmModel {
            inducing: vec![0.5, -0.5, 0.25, 0.75],
            kinv_y: (0..2 * 3).map(|i| i as f64 * 0.5).collect(),
            ..m("s", 4, 3)
        };
        let models = vec![m("a", 3, 4), sparse, m("b", 2, 1)];
        let path = dir.path().join("m.parquet");
        write_models(&path, &models, &prov()).unwrap();
        let back = read_models(&path).unwrap();
        assert_eq!(back, models);
        assert!(back[1].is_sparse() && back[1].m() == 2 && back[1].n() == 4 && !back[0].is_sparse());
        let latents = Latents {
            label: vec!["a".into(), "b".into()],
            segment_id: vec![0, 3],
            clip: vec!["c".into(), "d".into()],
            frame: vec![5, 6],
            time: vec![0.0, 0.25],
            x: vec![vec![1.0, 2.0], vec![3.0, 4.0]],
        };
        let path = dir.path().join("l.parquet");
        write_latents(&path, &latents, &prov()).unwrap();
        assert_eq!(read_latents(&path).unwrap(), latents);
    }

    /// Fit summaries come back as written: with the held-out and generative checks, with
    /// the check off (nulls and zeros), with two fit stages, and an unfilled window's
    /// `rel_decrease = inf`; a table of the previous version is refused.
    #[test]
    fn fits_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let on = FitSummary {
            label: "happy".into(),
            frames: 520,
            d: 5,
            q: 3,
            inducing_points: 0,
            optimizer: "lbfgs".into(),
            connectivity_path: "coarse".into(),
            stage_iterations: vec![1372],
            iterations: 1372,
            evaluations: 1400,
            initial_objective: 9000.5,
            objective: 3000.25,
            neg_log_likelihood: 2900.0,
            dynamics: 80.0,
            connectivity: 19.0,
            signal: 1.25,
            connectivity_exact: Some(19.5),
            grad_norm: 1e-3,
            rel_decrease: 1e-10,
            rel_gradient: 2e-6,
            jitter: 1e-8,
            dynamics_jitter: 0.0,
            converged: true,
            stop_reason: "converged".into(),
            seconds: 11.1,
            heldout_gplvm_mesh_rmse: Some(0.25),
            heldout_pca_q_mesh_rmse: Some(0.4),
            heldout_pca_d_mesh_rmse: Some(0.2),
            heldout_d: 5,
            heldout_frames: 52,
            generative_gplvm_mesh_rmse: Some(0.3),
            generative_interp_mesh_rmse: Some(0.1),
            generative_interp_d_mesh_rmse: Some(0.15),
            generative_frames: 50,
        };
        let off = FitSummary {
            label: "roar".into(),
            inducing_points: 100,
            connectivity_exact: None,
            stage_iterations: vec![12, 34],
            rel_decrease: f64::INFINITY,
            converged: false,
            stop_reason: "max-iterations".into(),
            heldout_gplvm_mesh_rmse: None,
            heldout_pca_q_mesh_rmse: None,
            heldout_pca_d_mesh_rmse: None,
            heldout_d: 0,
            heldout_frames: 0,
            generative_gplvm_mesh_rmse: None,
            generative_interp_mesh_rmse: None,
            generative_interp_d_mesh_rmse: None,
            generative_frames: 0,
            ..on.clone()
        };
        let rows = vec![on, off];
        let path = dir.path().join("f.parquet");
        write_fits(&path, &rows, &prov()).unwrap();
        assert_eq!(read_fits(&path).unwrap(), rows);
        let old = dir.path().join("old.parquet");
        let v2 = Kind { version: 2, ..GPLVM_FITS };
        crate::table::write(&old, v2, Columns::new().str("label", &["a"]), &prov(), &[]).unwrap();
        let e = read_fits(&old).unwrap_err().to_string();
        assert!(e.contains("old.parquet"), "{e}");
    }
}
