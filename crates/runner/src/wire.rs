//! Wiring by artifact: what a stage leaves out of `pipeline.toml` is filled in from its
//! declaration ([`reprise_stagekit::wiring`]).
//!
//! - `bin` defaults to the known stage of the table's name (`[stage.gplvm]` runs
//!   `reprise-gplvm`);
//! - each declared output not given goes to `<artifacts>/<artifact>` (reports to
//!   `[pipeline] reports`, default `reports/<name>`);
//! - each declared input not given is wired to the one stage of the pipeline that writes
//!   that artifact — a declared output of that name, or, for a stage without a
//!   declaration, an output whose file is so named. A required input nobody writes, a
//!   source the user did not give, or two writers of one artifact are errors that say
//!   what to write in `pipeline.toml`;
//! - declared derived parameters (`name`, `lock` of `evaluate`) not given are set from
//!   the pipeline.
//!
//! Explicit paths always win, so every pipeline written before wiring means what it did.

use std::path::Path;

use reprise_stagekit::wiring::{Derived, Need, Place, Wiring};

use crate::error::{Error, Result};
use crate::params::{ParamValue, Scalar};
use crate::paths::ArtifactPath;
use crate::pipeline::{BinSpec, Stage};

/// The declaration for a stage running `bin`.
pub fn find<'a>(known: &'a [Wiring], bin: &BinSpec) -> Option<&'a Wiring> {
    let name = match bin {
        BinSpec::Name(n) => n.as_str(),
        BinSpec::Path(p) => Path::new(&p.rel).file_name()?.to_str()?,
    };
    known.iter().find(|w| w.bin == name)
}

/// Where the pipeline's artifacts and reports go, relative to the pipeline directory.
pub struct Places<'a> {
    /// The pipeline directory (absolute).
    pub dir: &'a Path,
    /// `[pipeline] artifacts`, as declared (default `artifacts/<name>`).
    pub artifacts: &'a str,
    /// `[pipeline] reports`, as declared (default `reports/<name>`).
    pub reports: &'a str,
    /// `[pipeline] name`.
    pub name: &'a str,
    /// The lock file, relative to `dir`.
    pub lock: String,
}

/// Fills in the outputs and derived parameters of every declared stage (`wirings[i]` is
/// stage `i`'s declaration).
pub fn outputs(stages: &mut [Stage], wirings: &[Option<&Wiring>], places: &Places<'_>) {
    for (stage, w) in stages.iter_mut().zip(wirings) {
        let Some(w) = w else { continue };
        for out in w.outputs {
            if stage.outputs.iter().any(|(n, _)| n == out.role) {
                continue;
            }
            let rel = match out.place {
                Place::Artifacts => format!("{}/{}", places.artifacts, out.artifact),
                Place::Reports => format!("{}/{}", places.reports, out.artifact),
            };
            stage.outputs.push((out.role.to_string(), ArtifactPath::new(places.dir, &rel)));
        }
        for (param, derived) in w.derived {
            if stage.params.iter().any(|(n, _)| n == param) {
                continue;
            }
            let value = match derived {
                Derived::PipelineName => places.name.to_string(),
                Derived::LockFile => places.lock.clone(),
            };
            stage.params.push((param.to_string(), ParamValue::Scalar(Scalar::Str(value))));
        }
    }
}

/// Wires the inputs of every declared stage to their writers (outputs already filled).
pub fn inputs(stages: &mut [Stage], wirings: &[Option<&Wiring>], file: &str) -> Result<()> {
    // (artifact name, stage, output path) of every output in the pipeline.
    let mut written: Vec<(String, String, ArtifactPath)> = Vec::new();
    for (stage, w) in stages.iter().zip(wirings) {
        for (role, path) in &stage.outputs {
            let declared = w.and_then(|w| w.outputs.iter().find(|o| o.role == role)).map(|o| o.artifact);
            let artifact = declared.map_or_else(
                || Path::new(&path.rel).file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned()),
                str::to_string,
            );
            written.push((artifact, stage.name.clone(), path.clone()));
        }
    }
    for (stage, w) in stages.iter_mut().zip(wirings) {
        let Some(w) = w else { continue };
        for input in w.inputs {
            if stage.inputs.iter().any(|(n, _)| crate::pipeline::input_role(n) == input.role) {
                continue;
            }
            let writers: Vec<&(String, String, ArtifactPath)> =
                written.iter().filter(|(a, s, _)| a == input.artifact && *s != stage.name).collect();
            let unwired = |why: String| Error::Unwired {
                file: file.into(),
                stage: stage.name.clone(),
                input: input.role.into(),
                why,
            };
            match (input.need, writers.as_slice()) {
                (Need::Source, _) => {
                    return Err(unwired(format!(
                        "it is your own file ({}): give `inputs.{} = \"<path>\"`",
                        input.artifact, input.role
                    )))
                }
                (Need::OptionalSource, _) | (Need::Optional, []) => {}
                (Need::Required, []) => {
                    return Err(unwired(format!(
                        "it reads `{}`, which no stage of this pipeline writes: add the stage that writes it, or give \
                         `inputs.{} = \"<path>\"`",
                        input.artifact, input.role
                    )))
                }
                (_, [(_, _, path)]) => stage.inputs.push((input.role.to_string(), path.clone())),
                (_, [(_, a, _), (_, b, ..), ..]) => {
                    return Err(unwired(format!(
                        "stages `{a}` and `{b}` both write `{}`: give `inputs.{} = \"<path>\"` to say which",
                        input.artifact, input.role
                    )))
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use reprise_stagekit::wiring::{self, Derived, Wiring};

    use crate::error::Error;
    use crate::pipeline::Pipeline;

    const KNOWN: [Wiring; 3] = [
        Wiring {
            stage: "make",
            bin: "reprise-make",
            inputs: &[wiring::source("recipe", "a recipe file")],
            outputs: &[wiring::artifact("dough", "dough.parquet"), wiring::artifact("crumbs", "crumbs.parquet")],
            derived: &[],
            partition: wiring::Partition::Whole,
        },
        Wiring {
            stage: "bake",
            bin: "reprise-bake",
            inputs: &[wiring::required("dough", "dough.parquet"), wiring::optional("icing", "icing.parquet")],
            outputs: &[wiring::artifact("cake", "cake.parquet")],
            derived: &[],
            partition: wiring::Partition::Whole,
        },
        Wiring {
            stage: "taste",
            bin: "reprise-taste",
            inputs: &[wiring::required("cake", "cake.parquet"), wiring::optional_source("notes", "notes")],
            outputs: &[wiring::report("verdict", "verdict.md")],
            derived: &[("name", Derived::PipelineName), ("lock", Derived::LockFile)],
            partition: wiring::Partition::Whole,
        },
    ];

    fn parse(text: &str) -> Result<Pipeline, Error> {
        let dir = tempfile::tempdir().unwrap();
        Pipeline::parse_wired(text, "pipeline.toml", dir.path(), &KNOWN)
    }

    fn rel<'a>(p: &'a Pipeline, stage: &str, input: bool, role: &str) -> Option<&'a str> {
        let s = p.stage(stage).unwrap();
        let list = if input { &s.inputs } else { &s.outputs };
        list.iter().find(|(n, _)| n == role).map(|(_, a)| a.rel.as_str())
    }

    /// Three stage tables and a source: every output placed, every input wired, the
    /// derived parameters set, optional inputs without a writer left out.
    #[test]
    fn a_short_pipeline_is_wired_by_artifact() {
        let p = parse(
            "[pipeline]\nname = \"cakes\"\n[stage.make]\ninputs.recipe = \"recipe.toml\"\n[stage.bake]\n[stage.taste]\n",
        )
        .unwrap();
        assert_eq!(rel(&p, "make", false, "dough"), Some("artifacts/cakes/dough.parquet"));
        assert_eq!(rel(&p, "bake", true, "dough"), Some("artifacts/cakes/dough.parquet"));
        assert_eq!(rel(&p, "bake", true, "icing"), None, "no writer: left out");
        assert_eq!(rel(&p, "taste", true, "cake"), Some("artifacts/cakes/cake.parquet"));
        assert_eq!(rel(&p, "taste", false, "verdict"), Some("reports/cakes/verdict.md"));
        assert_eq!(rel(&p, "taste", true, "notes"), None);
        let taste = p.stage("taste").unwrap();
        let param = |n: &str| taste.params.iter().find(|(k, _)| k == n).map(|(_, v)| format!("{v:?}"));
        assert!(param("name").is_some_and(|v| v.contains("cakes")), "{:?}", taste.params);
        assert!(param("lock").is_some_and(|v| v.contains("artifacts/cakes/reprise.lock")), "{:?}", taste.params);
        assert!(matches!(&p.stage("bake").unwrap().bin, crate::pipeline::BinSpec::Name(b) if b == "reprise-bake"));
    }

    /// An explicit path wins, and a consumer follows the writer's override.
    #[test]
    fn explicit_paths_win_and_are_followed() {
        let p = parse(
            "[pipeline]\nname = \"c\"\nartifacts = \"out\"\n[stage.make]\ninputs.recipe = \"r.toml\"\n\
             outputs.dough = \"elsewhere/d.parquet\"\n[stage.bake]\n[stage.taste]\ninputs.cake = \"mine.parquet\"\n\
             params.name = \"other\"\n",
        )
        .unwrap();
        assert_eq!(rel(&p, "bake", true, "dough"), Some("elsewhere/d.parquet"));
        assert_eq!(rel(&p, "make", false, "crumbs"), Some("out/crumbs.parquet"));
        assert_eq!(rel(&p, "taste", true, "cake"), Some("mine.parquet"));
        let taste = p.stage("taste").unwrap();
        assert_eq!(taste.params.iter().filter(|(k, _)| k == "name").count(), 1);
    }

    /// What cannot be wired says what to write.
    #[test]
    fn what_cannot_be_wired_is_a_clear_error() {
        let e = parse("[pipeline]\nname = \"c\"\n[stage.bake]\n").unwrap_err().to_string();
        assert!(e.contains("stage `bake`: input `dough`") && e.contains("no stage of this pipeline writes"), "{e}");
        assert!(e.contains("inputs.dough = \"<path>\""), "{e}");
        let e = parse("[pipeline]\nname = \"c\"\n[stage.make]\n").unwrap_err().to_string();
        assert!(e.contains("input `recipe`") && e.contains("your own file"), "{e}");
        let e = parse(
            "[pipeline]\nname = \"c\"\n[stage.make]\ninputs.recipe = \"r\"\n[stage.again]\nbin = \"reprise-make\"\n\
             inputs.recipe = \"r\"\noutputs.dough = \"b/dough.parquet\"\noutputs.crumbs = \"b/crumbs.parquet\"\n[stage.bake]\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("stages `make` and `again` both write `dough.parquet`"), "{e}");
        let e = parse("[pipeline]\nname = \"c\"\n[stage.mystery]\n").unwrap_err().to_string();
        assert!(e.contains("stage `mystery` has no `bin`") && e.contains("`make`, `bake`, `taste`"), "{e}");
        assert_eq!(
            parse("[pipeline]\nname = \"c\"\n[stage.bake]\n").unwrap_err().code(),
            reprise_stagekit::exit::CONFIG
        );
    }

    /// A stage without a declaration is wired to by its output's file name.
    #[test]
    fn an_undeclared_writer_is_found_by_file_name() {
        let p = parse(
            "[pipeline]\nname = \"c\"\n[stage.mine]\nbin = \"my-dough-maker\"\noutputs.out = \"x/dough.parquet\"\n[stage.bake]\n",
        )
        .unwrap();
        assert_eq!(rel(&p, "bake", true, "dough"), Some("x/dough.parquet"));
    }
}
