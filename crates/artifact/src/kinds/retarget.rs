//! `retarget`: a fitted semi-supervised retargeting model (Bouaziz and Pauly): one row per
//! latent point of the shared GPLVM, in the model's order (the labelled pairs, the
//! source-only frames, the target-only poses), with the normalised data each space owns.
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `role` | Utf8 | `labelled`, `source` (capture only) or `target` (a character pose only) |
//! | `clip`, `frame` | Utf8, Int64 | the capture's frame (labelled, source) or the corpus frame (target) |
//! | `z0…` | Float64 | the latent point |
//! | `x0…` | Float64, null | the normalised capture values (null on target rows) |
//! | `y0…` | Float64, null | the normalised target coordinates (null on source rows) |
//!
//! Metadata: `reprise.retarget`, the JSON of [`Settings`]: the markers, the character's
//! controls, both normalisations, both kernels, the target space and the noise levels.
//!
//! `retarget_frames`: what mapping a capture did, one row per (clip, frame).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `clip`, `frame` | Utf8, Int64 | the capture's frame |
//! | `residual` | Float64 | RMS over the seen capture values of $\tilde x - x^*$, capture units |
//! | `variance` | Float64 | the source GP's predictive variance $\sigma_p^2(z^*)$, normalised units² |
//! | `missing` | Int64 | capture values treated as unseen |
//! | `ms` | Float64 | milliseconds the frame's solve took |
//! | `mesh_error` | Float64, null | RMS vertex distance to the known target pose, the rig's length unit |
//! | `trained` | Boolean | the frame is a row of the model (labelled or unlabelled): not held out |
//!
//! `retarget_comparison`: protocol A, one row per (label count, method).
//!
//! | column | type | meaning |
//! |---|---|---|
//! | `labels` | Int64 | labelled pairs |
//! | `method` | Utf8 | the method's name |
//! | `rms` | Float64 | mean over draws of the RMS target error, target units |
//! | `sd` | Float64 | its standard deviation over draws |
//! | `draws` | Int64 | random draws of the labelled frames |

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::provenance::Provenance;
use crate::table::{Columns, Kind, Table};

/// Kind of the retargeting model table.
pub const RETARGET: Kind = Kind { name: "retarget", version: 1 };
/// Kind of the per-frame table of a mapping.
pub const RETARGET_FRAMES: Kind = Kind { name: "retarget_frames", version: 1 };
/// Kind of protocol A's table.
pub const RETARGET_COMPARISON: Kind = Kind { name: "retarget_comparison", version: 1 };
/// Metadata key: the model's settings.
pub const KEY_RETARGET: &str = "reprise.retarget";
/// Most latent rows a model may hold (every mapping builds dense kernels over them).
pub const MAX_ROWS: usize = 4_000;
/// Most capture values or target coordinates per row.
pub const MAX_VALUES: usize = 100_000;

/// A latent row's role.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    /// A labelled pair: a capture frame and the character's pose for it.
    Labelled,
    /// A capture frame without a pose.
    Source,
    /// A character pose without a capture frame.
    Target,
}

impl Role {
    /// The `role` column's value.
    pub fn name(self) -> &'static str {
        match self {
            Role::Labelled => "labelled",
            Role::Source => "source",
            Role::Target => "target",
        }
    }
}

/// $(\bar v, s)$ of a normalisation $\hat v = (v - \bar v)/s$.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Normalisation {
    /// $\bar v$.
    pub mean: Vec<f64>,
    /// $s$.
    pub scale: f64,
}

/// The target space (see `reprise_retarget::target`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetSpace {
    /// Per control, its weight (mesh length per control unit; 0 = held).
    pub weights: Vec<f64>,
    /// Value of each held control.
    pub held: Vec<f64>,
    /// Mean of the scaled poses.
    pub mean: Vec<f64>,
    /// Kept directions, row-major `d × controls`.
    pub directions: Vec<f64>,
    /// Share of the scaled poses' variance kept.
    pub explained: f64,
}

/// The fit's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitInfo {
    /// L-BFGS iterations.
    pub iterations: usize,
    /// The objective at the end.
    pub objective: f64,
    /// Whether a convergence test stopped it.
    pub converged: bool,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// The model's settings and everything but the rows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// The capture's points (markers), in the order of its values.
    pub points: Vec<i64>,
    /// The character's controls, in the order of the target space.
    pub controls: Vec<String>,
    /// Latent dimension.
    pub q: usize,
    /// The capture's normalisation.
    pub source: Normalisation,
    /// The target coordinates' normalisation.
    pub target: Normalisation,
    /// The source kernel, $(\log\sigma_f^2, \log\ell, \log\sigma_w^2)$.
    pub source_kernel: [f64; 3],
    /// The target kernel.
    pub target_kernel: [f64; 3],
    /// The character's controls as coordinates.
    pub space: TargetSpace,
    /// $\sigma_c$, capture units.
    pub capture_noise: f64,
    /// $\sigma_t$, capture units: $\sqrt{s^2 - \sigma_c^2}$ of the RMS step $s$ between
    /// consecutive capture frames (at least $s/10$; 0: no temporal term).
    pub temporal_noise: f64,
    /// LLE neighbours (0: no LLE prior).
    pub lle_neighbours: usize,
    /// The fit.
    pub fit: FitInfo,
    /// The capture's frame rate.
    pub fps: f64,
}

impl Settings {
    /// Whether the settings fit together: three capture values per point, one weight, held
    /// value and mean per control, directions of the coordinates' length, positive finite
    /// scales, finite kernels and noise levels.
    ///
    /// # Errors
    /// The first relation that does not hold, in words.
    pub fn check(&self) -> std::result::Result<(), String> {
        let (dx, dy, c) = (self.source.mean.len(), self.target.mean.len(), self.controls.len());
        let sp = &self.space;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if dx != 3 * self.points.len() {
            return Err(format!("{dx} capture values for {} points (3 each)", self.points.len()));
        }
        if [sp.weights.len(), sp.held.len(), sp.mean.len()].iter().any(|&l| l != c) {
            return Err(format!("the target space's weights, held values and mean must have one per control ({c})"));
        }
        if sp.directions.len() != dy * c {
            return Err(format!(
                "{} direction values where {dy} coordinates × {c} controls are expected",
                sp.directions.len()
            ));
        }
        let scales = [self.source.scale, self.target.scale];
        if !scales.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(format!("normalisation scales {scales:?} must be finite and positive"));
        }
        let all = [
            &self.source.mean[..],
            &self.target.mean,
            &self.source_kernel,
            &self.target_kernel,
            &sp.weights,
            &sp.held,
            &sp.mean,
            &sp.directions,
        ];
        let noise_ok = self.capture_noise > 0.0
            && self.capture_noise.is_finite()
            && self.temporal_noise >= 0.0
            && self.temporal_noise.is_finite();
        if !(noise_ok && all.iter().all(|v| finite(v))) {
            return Err("a value is not finite, or a noise level is not positive".into());
        }
        Ok(())
    }
}

/// A fitted model.
#[derive(Debug, Clone, PartialEq)]
pub struct Retarget {
    /// Role per latent row: labelled rows, then source rows, then target rows.
    pub role: Vec<Role>,
    /// Clip per row.
    pub clip: Vec<String>,
    /// Frame per row.
    pub frame: Vec<i64>,
    /// Latents, `rows × q`.
    pub z: Vec<f64>,
    /// Normalised capture values of the labelled and source rows, in row order.
    pub x: Vec<f64>,
    /// Normalised target coordinates of the labelled and target rows, in row order.
    pub y: Vec<f64>,
    /// The rest.
    pub settings: Settings,
}

impl Retarget {
    /// Rows of each role: (labelled, source, target).
    pub fn counts(&self) -> (usize, usize, usize) {
        let c = |r: Role| self.role.iter().filter(|&&x| x == r).count();
        (c(Role::Labelled), c(Role::Source), c(Role::Target))
    }

    /// Writes the table atomically.
    pub fn write(&self, path: &Path, provenance: &Provenance) -> Result<()> {
        let s = &self.settings;
        let (dx, dy, q) = (s.source.mean.len(), s.target.mean.len(), s.q);
        let roles: Vec<&str> = self.role.iter().map(|r| r.name()).collect();
        let mut cols = Columns::new().str("role", &roles).str("clip", &self.clip).i64("frame", self.frame.clone());
        for j in 0..q {
            cols = cols.f64(&format!("z{j}"), self.z.chunks_exact(q).map(|r| r[j]).collect());
        }
        let spread = |data: &[f64], d: usize, skip: Role, j: usize| -> Vec<Option<f64>> {
            let mut it = data.chunks_exact(d);
            self.role.iter().map(|&r| if r == skip { None } else { it.next().map(|v| v[j]) }).collect()
        };
        for j in 0..dx {
            cols = cols.f64_opt(&format!("x{j}"), spread(&self.x, dx, Role::Target, j));
        }
        for j in 0..dy {
            cols = cols.f64_opt(&format!("y{j}"), spread(&self.y, dy, Role::Source, j));
        }
        let meta = vec![(KEY_RETARGET.into(), serde_json::to_string(s).expect("the settings serialise"))];
        crate::table::write(path, RETARGET, cols, provenance, &meta)
    }

    /// Reads the table, checking the rows' order and that every value each role needs is
    /// there.
    pub fn read(path: &Path) -> Result<Self> {
        let table = Table::read(path, RETARGET)?;
        let settings: Settings = serde_json::from_str(table.meta(KEY_RETARGET)?)
            .map_err(|e| table.invalid(format!("metadata `{KEY_RETARGET}`: {e}")))?;
        let (dx, dy, q) = (settings.source.mean.len(), settings.target.mean.len(), settings.q);
        if table.rows() > MAX_ROWS || dx > MAX_VALUES || dy > MAX_VALUES || q == 0 || q > 64 {
            return Err(table.invalid(format!(
                "{} rows, {dx} capture values, {dy} coordinates, q = {q}: beyond the limits ({MAX_ROWS} rows, \
                 {MAX_VALUES} values; q in 1..=64)",
                table.rows()
            )));
        }
        settings.check().map_err(|m| table.invalid(format!("metadata `{KEY_RETARGET}`: {m}")))?;
        let role = table
            .str("role")?
            .iter()
            .enumerate()
            .map(|(r, s)| match *s {
                "labelled" => Ok(Role::Labelled),
                "source" => Ok(Role::Source),
                "target" => Ok(Role::Target),
                other => {
                    Err(table.invalid(format!("row {r}, column `role`: `{other}` is not labelled, source or target")))
                }
            })
            .collect::<Result<Vec<_>>>()?;
        if let Some(r) = role.windows(2).position(|w| rank(w[1]) < rank(w[0])) {
            return Err(table.invalid(format!("row {}: the rows are not labelled, then source, then target", r + 1)));
        }
        let clip = table.strings("clip")?;
        let frame = table.i64("frame")?.to_vec();
        let mut z = Vec::with_capacity(table.rows() * q);
        let zc: Vec<&[f64]> = (0..q).map(|j| table.f64(&format!("z{j}"))).collect::<Result<_>>()?;
        for r in 0..table.rows() {
            z.extend(zc.iter().map(|c| c[r]));
        }
        let gather = |prefix: &str, d: usize, skip: Role| -> Result<Vec<f64>> {
            let cols: Vec<Vec<Option<f64>>> =
                (0..d).map(|j| table.f64_opt(&format!("{prefix}{j}"))).collect::<Result<_>>()?;
            let mut out = Vec::new();
            for (r, &ro) in role.iter().enumerate().filter(|(_, &ro)| ro != skip) {
                for (j, c) in cols.iter().enumerate() {
                    out.push(c[r].ok_or_else(|| {
                        table.invalid(format!("row {r}, column `{prefix}{j}`: a {} row needs a value", ro.name()))
                    })?);
                }
            }
            Ok(out)
        };
        let x = gather("x", dx, Role::Target)?;
        let y = gather("y", dy, Role::Source)?;
        if role.iter().filter(|&&r| r == Role::Labelled).count() < 2 || z.iter().any(|v| !v.is_finite()) {
            return Err(table.invalid("a model needs at least two labelled rows and finite latents"));
        }
        Ok(Self { role, clip, frame, z, x, y, settings })
    }
}

fn rank(r: Role) -> u8 {
    match r {
        Role::Labelled => 0,
        Role::Source => 1,
        Role::Target => 2,
    }
}

/// One mapped capture frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MappedFrame {
    /// Clip.
    pub clip: String,
    /// Frame.
    pub frame: i64,
    /// Capture residual, capture units.
    pub residual: f64,
    /// Predictive variance, normalised units².
    pub variance: f64,
    /// Capture values treated as unseen.
    pub missing: i64,
    /// Milliseconds.
    pub ms: f64,
    /// RMS vertex distance to the known pose, where one is known.
    pub mesh_error: Option<f64>,
    /// Whether the frame is a row of the model (not held out).
    pub trained: bool,
}

/// Writes the per-frame table atomically.
pub fn write_frames(path: &Path, rows: &[MappedFrame], provenance: &Provenance) -> Result<()> {
    let clip: Vec<&str> = rows.iter().map(|r| r.clip.as_str()).collect();
    let cols = Columns::new()
        .str("clip", &clip)
        .i64("frame", rows.iter().map(|r| r.frame).collect())
        .f64("residual", rows.iter().map(|r| r.residual).collect())
        .f64("variance", rows.iter().map(|r| r.variance).collect())
        .i64("missing", rows.iter().map(|r| r.missing).collect())
        .f64("ms", rows.iter().map(|r| r.ms).collect())
        .f64_opt("mesh_error", rows.iter().map(|r| r.mesh_error).collect())
        .bool("trained", rows.iter().map(|r| r.trained).collect());
    crate::table::write(path, RETARGET_FRAMES, cols, provenance, &[])
}

/// Reads the per-frame table.
pub fn read_frames(path: &Path) -> Result<Vec<MappedFrame>> {
    let t = Table::read(path, RETARGET_FRAMES)?;
    let trained = t.bool("trained")?;
    let (clip, frame, residual, variance, missing, ms, mesh) = (
        t.strings("clip")?,
        t.i64("frame")?,
        t.f64("residual")?,
        t.f64("variance")?,
        t.i64("missing")?,
        t.f64("ms")?,
        t.f64_opt("mesh_error")?,
    );
    Ok((0..t.rows())
        .map(|r| MappedFrame {
            clip: clip[r].clone(),
            frame: frame[r],
            residual: residual[r],
            variance: variance[r],
            missing: missing[r],
            ms: ms[r],
            mesh_error: mesh[r],
            trained: trained[r],
        })
        .collect())
}

/// One method at one label count of protocol A.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Labelled pairs.
    pub labels: i64,
    /// The method's name.
    pub method: String,
    /// Mean over draws of the RMS target error.
    pub rms: f64,
    /// Standard deviation over draws.
    pub sd: f64,
    /// Draws.
    pub draws: i64,
}

/// Writes protocol A's table atomically.
pub fn write_comparison(path: &Path, rows: &[Comparison], provenance: &Provenance) -> Result<()> {
    let method: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    let cols = Columns::new()
        .i64("labels", rows.iter().map(|r| r.labels).collect())
        .str("method", &method)
        .f64("rms", rows.iter().map(|r| r.rms).collect())
        .f64("sd", rows.iter().map(|r| r.sd).collect())
        .i64("draws", rows.iter().map(|r| r.draws).collect());
    crate::table::write(path, RETARGET_COMPARISON, cols, provenance, &[])
}

/// Reads protocol A's table.
pub fn read_comparison(path: &Path) -> Result<Vec<Comparison>> {
    let t = Table::read(path, RETARGET_COMPARISON)?;
    let (labels, method, rms, sd, draws) =
        (t.i64("labels")?, t.strings("method")?, t.f64("rms")?, t.f64("sd")?, t.i64("draws")?);
    Ok((0..t.rows())
        .map(|r| Comparison { labels: labels[r], method: method[r].clone(), rms: rms[r], sd: sd[r], draws: draws[r] })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Retarget {
        let norm = |d: usize| Normalisation { mean: vec![0.5; d], scale: 2.0 };
        Retarget {
            role: vec![Role::Labelled, Role::Labelled, Role::Source, Role::Target],
            clip: vec!["take".into(), "take".into(), "take".into(), "idle".into()],
            frame: vec![0, 5, 9, 3],
            z: (0..8).map(f64::from).collect(),
            x: (0..9).map(|v| f64::from(v) * 0.1).collect(),
            y: (0..6).map(|v| f64::from(v) * -0.2).collect(),
            settings: Settings {
                points: vec![4],
                controls: vec!["jaw".into(), "smile".into()],
                q: 2,
                source: norm(3),
                target: norm(2),
                source_kernel: [0.0, 0.1, -4.0],
                target_kernel: [0.2, 0.0, -3.0],
                space: TargetSpace {
                    weights: vec![1.0, 0.0],
                    held: vec![0.0, 0.3],
                    mean: vec![0.1, 0.0],
                    directions: vec![1.0, 0.0, 0.0, 1.0],
                    explained: 1.0,
                },
                capture_noise: 1e-3,
                temporal_noise: 2e-3,
                lle_neighbours: 8,
                fit: FitInfo { iterations: 12, objective: -3.5, converged: true, seconds: 0.5 },
                fps: 60.0,
            },
        }
    }

    #[test]
    fn round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.parquet");
        let r = sample();
        r.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        assert_eq!(Retarget::read(&path).unwrap(), r);
        assert_eq!(r.counts(), (2, 1, 1));
        let rows = vec![MappedFrame {
            clip: "take".into(),
            frame: 3,
            residual: 0.1,
            variance: 0.01,
            missing: 10,
            ms: 2.5,
            mesh_error: None,
            trained: true,
        }];
        let fpath = dir.path().join("f.parquet");
        write_frames(&fpath, &rows, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read_frames(&fpath).unwrap(), rows);
        let table = vec![Comparison { labels: 5, method: "GPR".into(), rms: 0.07, sd: 0.01, draws: 20 }];
        let cpath = dir.path().join("c.parquet");
        write_comparison(&cpath, &table, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        assert_eq!(read_comparison(&cpath).unwrap(), table);
    }

    #[test]
    fn settings_that_do_not_fit_together_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.parquet");
        let mut r = sample();
        r.settings.points.push(11);
        r.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        let err = Retarget::read(&path).unwrap_err().to_string();
        assert!(err.contains("3 capture values for 2 points"), "{err}");
        let mut r = sample();
        r.settings.space.directions.pop();
        r.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        assert!(Retarget::read(&path).unwrap_err().to_string().contains("direction values"));
    }

    #[test]
    fn rows_out_of_order_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.parquet");
        let mut r = sample();
        r.role.swap(1, 2);
        // Keep the data consistent with the swapped roles (x on rows 0–2 still).
        r.write(&path, &Provenance::new("test", "0", serde_json::json!({}))).unwrap();
        let err = Retarget::read(&path).unwrap_err().to_string();
        assert!(err.contains("row 2") && err.contains("labelled, then source"), "{err}");
    }
}
