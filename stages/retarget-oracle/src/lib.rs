//! The retarget-oracle stage: a **stated** correspondence from a capture's channels (e.g.
//! ARKit shape weights) to a character's controls, which poses the character for every
//! capture frame. It stands in for the animator who would pose the labelled frames, so a
//! retargeting method can be scored against a known map (in the character's mesh units).
//! It measures how well a known map is recovered, not artistic quality.
//!
//! The correspondence file (TOML) lists one `[[map]]` per character control:
//!
//! ```toml
//! [[map]]
//! control = "jaw_open"      # the character's control
//! from = ["jawOpen"]        # capture channels
//! coefficients = [1.0]      # optional, 1 each by default
//! gain = 40.0               # optional, 1
//! power = 0.8               # optional, 1
//! offset = 0.0              # optional, 0
//! ```
//!
//! With $s = \mathrm{clamp}(\sum_i c_i w_i, -1, 1)$, the control is
//! $\text{offset} + \text{gain}\cdot\operatorname{sign}(s)\,|s|^{\text{power}}$, clamped to
//! the control's range; controls the file does not name stay at their rest value.
//!
//! Outputs: `truth`, the character's pose for every capture frame (a frame table keyed by
//! the capture's clip and frame), and `pairs`, `--labels` of them spread evenly over the
//! capture: the labelled pairs `retarget-fit` reads.

use clap::Parser;
use reprise_artifact::controls::Controls;
use reprise_artifact::frames::Frames;
use reprise_stagekit::{StageError, StageResult};
use serde::{Deserialize, Serialize};

reprise_stagekit::stage_io! {
    stage: "retarget-oracle", bin: "reprise-retarget-oracle",
    partition: Whole,
    derived: [],
    inputs {
        /// Input: the capture's channels per frame (a frame table, e.g. ARKit weights).
        source: required "source.parquet",
        /// Input: the character's controls table.
        controls: required "controls.parquet",
        /// Input: the correspondence (.toml).
        correspondence: required "correspondence.toml",
    }
    outputs {
        /// Output: the character's pose for every capture frame.
        truth: artifact "truth.parquet",
        /// Output: the labelled pairs, a subset of `truth`.
        pairs: artifact "pairs.parquet",
    }
}

/// `reprise-retarget-oracle`: a stated correspondence poses the character.
#[derive(Debug, Clone, Parser, Serialize)]
#[command(name = "reprise-retarget-oracle", version, about)]
pub struct Args {
    /// The stage's files.
    #[command(flatten)]
    #[serde(skip)]
    pub io: Io,
    /// Labelled pairs to write, spread evenly over the capture's frames.
    #[arg(long, default_value_t = 10)]
    pub labels: usize,
}

/// One control's rule.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rule {
    /// The character's control.
    pub control: String,
    /// Capture channels.
    pub from: Vec<String>,
    /// Their coefficients (1 each when absent).
    #[serde(default)]
    pub coefficients: Vec<f64>,
    /// Gain.
    #[serde(default = "one")]
    pub gain: f64,
    /// Power.
    #[serde(default = "one")]
    pub power: f64,
    /// Offset.
    #[serde(default)]
    pub offset: f64,
}

fn one() -> f64 {
    1.0
}

/// The correspondence file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Correspondence {
    /// The rules.
    pub map: Vec<Rule>,
}

/// A rule resolved against the capture's channels and the character's controls.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolved {
    control: usize,
    inputs: Vec<(usize, f64)>,
    gain: f64,
    power: f64,
    offset: f64,
    range: (f64, f64),
}

impl Resolved {
    /// The control's value for one capture frame `w`.
    pub fn value(&self, w: &[f64]) -> f64 {
        let s = self.inputs.iter().map(|&(i, c)| c * w[i]).sum::<f64>().clamp(-1.0, 1.0);
        (self.offset + self.gain * s.signum() * s.abs().powf(self.power)).clamp(self.range.0, self.range.1)
    }
}

/// Parses and resolves a correspondence.
///
/// # Errors
/// Bad TOML, a rule naming a channel or control that does not exist, coefficients that do
/// not match `from`, a non-finite or non-positive power, a control named twice.
pub fn resolve(
    text: &str,
    path: &std::path::Path,
    channels: &[String],
    controls: &Controls,
) -> StageResult<Vec<Resolved>> {
    let bad = |m: String| StageError::Input(format!("{}: {m}", path.display()));
    let spec: Correspondence = toml::from_str(text).map_err(|e| bad(e.to_string()))?;
    let mut out: Vec<Resolved> = Vec::with_capacity(spec.map.len());
    for (k, r) in spec.map.iter().enumerate() {
        let at = format!("map {} (`{}`)", k + 1, r.control);
        let control = controls
            .controls
            .iter()
            .position(|c| c.name == r.control)
            .ok_or_else(|| bad(format!("{at}: the character has no such control")))?;
        if out.iter().any(|o| o.control == control) {
            return Err(bad(format!("{at}: the control is mapped twice")));
        }
        if r.from.is_empty() || (!r.coefficients.is_empty() && r.coefficients.len() != r.from.len()) {
            return Err(bad(format!("{at}: `from` needs channels, and `coefficients` one per channel")));
        }
        let finite = [r.gain, r.offset].iter().chain(&r.coefficients).all(|v| v.is_finite());
        if !(finite && r.power.is_finite() && r.power > 0.0) {
            return Err(bad(format!("{at}: gain, offset and coefficients must be finite, power positive")));
        }
        let inputs = r
            .from
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let ch = channels
                    .iter()
                    .position(|c| c == name)
                    .ok_or_else(|| bad(format!("{at}: the capture has no channel `{name}`")))?;
                Ok((ch, r.coefficients.get(i).copied().unwrap_or(1.0)))
            })
            .collect::<StageResult<_>>()?;
        let c = &controls.controls[control];
        if c.min.is_nan() || c.max.is_nan() || c.min > c.max {
            return Err(bad(format!("{at}: the control's range [{}, {}] is empty", c.min, c.max)));
        }
        out.push(Resolved { control, inputs, gain: r.gain, power: r.power, offset: r.offset, range: (c.min, c.max) });
    }
    Ok(out)
}

/// What the stage wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames posed.
    pub frames: usize,
    /// Controls the correspondence sets.
    pub mapped: usize,
    /// Labelled pairs written.
    pub labels: usize,
}

/// Runs the stage (or only validates, with `--check`).
pub fn run(args: &Args) -> StageResult<Option<Summary>> {
    if args.labels < 2 {
        return Err(StageError::Config(format!("--labels {}: at least 2", args.labels)));
    }
    if args.io.check {
        return Ok(None);
    }
    let provenance = args.io.provenance(args)?;
    let source = Frames::read(&args.io.source)?;
    let controls = Controls::read(&args.io.controls)?;
    let path = &args.io.correspondence;
    let text = std::fs::read_to_string(path).map_err(|e| StageError::Input(format!("{}: {e}", path.display())))?;
    let rules = resolve(&text, path, &source.controls, &controls)?;
    let c = controls.controls.len();
    let rest: Vec<f64> = controls.controls.iter().map(|k| k.default).collect();
    let mut values = Vec::with_capacity(source.rows() * c);
    for r in 0..source.rows() {
        let mut pose = rest.clone();
        for rule in &rules {
            pose[rule.control] = rule.value(source.row(r));
        }
        values.extend(pose);
    }
    let truth = Frames {
        fps: source.fps,
        controls: controls.controls.iter().map(|k| k.name.clone()).collect(),
        clip: source.clip.clone(),
        frame: source.frame.clone(),
        time: source.time.clone(),
        values,
    };
    let picked: Vec<usize> =
        (0..args.labels.min(truth.rows())).map(|i| i * truth.rows() / args.labels.min(truth.rows())).collect();
    let pairs = Frames {
        clip: picked.iter().map(|&r| truth.clip[r].clone()).collect(),
        frame: picked.iter().map(|&r| truth.frame[r]).collect(),
        time: picked.iter().map(|&r| truth.time[r]).collect(),
        values: picked.iter().flat_map(|&r| truth.row(r).iter().copied()).collect(),
        ..truth.clone()
    };
    truth.write(&args.io.truth, &provenance)?;
    pairs.write(&args.io.pairs, &provenance)?;
    Ok(Some(Summary { frames: truth.rows(), mapped: rules.len(), labels: pairs.rows() }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use reprise_artifact::controls::{Control, RigRef};

    fn controls() -> Controls {
        let c = |name: &str, min: f64, max: f64| Control {
            name: name.into(),
            group: "g".into(),
            unit: "slider".into(),
            default: 0.0,
            min,
            max,
            animated: true,
        };
        Controls {
            controls: vec![c("jaw", -5.0, 45.0), c("side", -12.0, 12.0)],
            rig: RigRef::DragonFace { seed: 7, version: "test".into() },
        }
    }

    #[test]
    fn a_rule_is_a_clamped_signed_power_of_a_weighted_sum() {
        let text = "[[map]]\ncontrol = \"jaw\"\nfrom = [\"open\"]\ngain = 40.0\npower = 0.5\n\
                    [[map]]\ncontrol = \"side\"\nfrom = [\"left\", \"right\"]\ncoefficients = [1.0, -1.0]\ngain = 10.0\n";
        let ch: Vec<String> = ["open", "left", "right"].map(String::from).to_vec();
        let rules = resolve(text, std::path::Path::new("c.toml"), &ch, &controls()).unwrap();
        assert!((rules[0].value(&[0.25, 0.0, 0.0]) - 20.0).abs() < 1e-12, "40 · √0.25");
        assert_eq!(rules[0].value(&[4.0, 0.0, 0.0]), 40.0, "the sum is clamped to 1");
        assert!((rules[1].value(&[0.0, 0.1, 0.4]) + 3.0).abs() < 1e-12, "10 · (0.1 − 0.4)");
        // Clamped to the control's range.
        let text = "[[map]]\ncontrol = \"side\"\nfrom = [\"open\"]\ngain = 50.0\n";
        let rules = resolve(text, std::path::Path::new("c.toml"), &ch, &controls()).unwrap();
        assert_eq!(rules[0].value(&[1.0, 0.0, 0.0]), 12.0);
    }

    #[test]
    fn bad_rules_are_named() {
        let ch: Vec<String> = vec!["open".into()];
        let err = |text: &str| resolve(text, std::path::Path::new("c.toml"), &ch, &controls()).unwrap_err().to_string();
        assert!(err("[[map]]\ncontrol = \"nose\"\nfrom = [\"open\"]\n").contains("no such control"));
        assert!(err("[[map]]\ncontrol = \"jaw\"\nfrom = [\"shut\"]\n").contains("no channel `shut`"));
        assert!(err("[[map]]\ncontrol = \"jaw\"\nfrom = [\"open\"]\npower = 0.0\n").contains("power positive"));
        assert!(err("[[map]]\ncontrol = \"jaw\"\nfrom = [\"open\"]\ncoefficients = [1.0, 2.0]\n")
            .contains("one per channel"));
        let twice = "[[map]]\ncontrol = \"jaw\"\nfrom = [\"open\"]\n[[map]]\ncontrol = \"jaw\"\nfrom = [\"open\"]\n";
        assert!(err(twice).contains("mapped twice"));
        assert!(err("[[map]]\ncontrol = \"jaw\"\nfrom = [\"open\"]\nbogus = 1\n").contains("bogus"));
    }
}
