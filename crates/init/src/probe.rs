//! The pipeline's first stages run on the source in a scratch directory, as `reprise run`
//! will run them: what the source's clips are, and which labels move too little to model.

use std::collections::BTreeMap;
use std::path::Path;

use reprise_artifact::segments::Segment;
use reprise_runner::child::{self, Outcome};
use reprise_runner::error::{Error, Result};
use reprise_runner::locate::{locate, BinDirs};
use reprise_runner::paths::ArtifactPath;
use reprise_runner::pipeline::Pipeline;

/// The latent dimension of the generated pipeline's GPLVMs (the gplvm stage's default `q`,
/// which the template leaves alone): a label whose PCA keeps fewer dimensions cannot be
/// fitted and is excluded.
pub const GPLVM_Q: usize = reprise_gplvm::DEFAULT_Q;

/// The pipeline's first stages run on the source in a scratch directory.
pub(crate) struct Probe<'a> {
    pipeline: &'a Pipeline,
    dirs: &'a BinDirs,
    scratch: tempfile::TempDir,
    interrupt: child::Interrupt,
}

impl<'a> Probe<'a> {
    pub(crate) fn new(pipeline: &'a Pipeline, dirs: &'a BinDirs) -> Result<Self> {
        let scratch = tempfile::Builder::new()
            .prefix("reprise-init")
            .tempdir()
            .map_err(|source| Error::Io { path: std::env::temp_dir(), source })?;
        Ok(Self { pipeline, dirs, scratch, interrupt: child::Interrupt::watch() })
    }

    /// A file of the scratch directory.
    pub(crate) fn file(&self, name: &str) -> std::path::PathBuf {
        self.scratch.path().join(name)
    }

    /// A generated labels file, written to the scratch directory.
    pub(crate) fn labels_file(&self, text: &str) -> Result<ArtifactPath> {
        let path = self.file("labels.toml");
        std::fs::write(&path, text).map_err(|source| Error::Io { path: path.clone(), source })?;
        Ok(ArtifactPath::new(&self.pipeline.dir, &path.to_string_lossy()))
    }

    /// Runs the pipeline's stage `name` with its outputs in the scratch directory, its
    /// inputs from there when a stage writes them, and `labels` as its labels file. Its
    /// output is kept and shown only when it fails.
    pub(crate) fn run(&self, name: &str, labels: Option<ArtifactPath>) -> Result<()> {
        let mut stage = self
            .pipeline
            .stage(name)
            .cloned()
            .ok_or_else(|| Error::Init(format!("the pipeline has no `{name}` stage")))?;
        let in_scratch = |path: &ArtifactPath| {
            let file = Path::new(&path.rel).file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            ArtifactPath::new(&self.pipeline.dir, &self.file(&file).to_string_lossy())
        };
        for (_, path) in &mut stage.outputs {
            *path = in_scratch(path);
        }
        let written =
            |p: &ArtifactPath| self.pipeline.stages.iter().any(|s| s.outputs.iter().any(|(_, o)| o.abs == p.abs));
        for (role, path) in &mut stage.inputs {
            match &labels {
                Some(given) if role == "labels" => *path = given.clone(),
                _ if written(path) => *path = in_scratch(path),
                _ => {}
            }
        }
        let bin = locate(&stage.bin, self.dirs).map_err(|searched| Error::StageBinaryMissing {
            stage: stage.name.clone(),
            bin: stage.bin.declared().into(),
            searched,
        })?;
        let log = self.file(&format!("{name}.log"));
        let call = child::Call { log: Some(&log), ..child::Call::default() };
        let outcome = child::invoke(&stage, &bin, &self.pipeline.dir, call, &self.interrupt)?;
        let failed = |what: String, code: i32| Error::InitProbe {
            stage: name.into(),
            what,
            output: std::fs::read_to_string(&log).unwrap_or_default().trim_end().to_string(),
            code,
        };
        match outcome {
            Outcome::Success => Ok(()),
            Outcome::Failed(code) => Err(failed(format!("exit code {code}"), code)),
            Outcome::Killed(signal) => Err(failed(
                format!("killed by signal {signal} ({})", child::signal_name(signal)),
                reprise_stagekit::exit::STAGE_CRASHED,
            )),
            Outcome::Interrupted(signal) => {
                Err(Error::Interrupted { stage: Some(name.into()), signal, name: child::signal_name(signal) })
            }
        }
    }

    /// Labels with `labels`, then scales and reduces: the labels that cannot be modeled,
    /// with why — those that barely move ([`crate::still`]) and those whose PCA keeps fewer
    /// than [`GPLVM_Q`] dimensions.
    pub(crate) fn thin_labels(&self, labels: &ArtifactPath) -> Result<BTreeMap<String, String>> {
        self.run("label", Some(labels.clone()))?;
        self.run("scale", None)?;
        self.run("pca", None)?;
        let read = |what: &str, e: &dyn std::fmt::Display| Error::Init(format!("reading what {what} wrote: {e}"));
        let lf = reprise_artifact::frames::LabeledFrames::read(&self.file("labeled_frames.parquet"))
            .map_err(|e| read("label", &e))?;
        let scales = reprise_artifact::scales::read(&self.file("scales.parquet")).map_err(|e| read("scale", &e))?;
        let weights = reprise_artifact::scales::mean_weights(&scales, &lf.frames.controls);
        let mut thin = crate::still::still_labels(&crate::still::label_motion(&lf, &weights));
        let (_, models) =
            reprise_artifact::pca::read_models(&self.file("pca_models.parquet")).map_err(|e| read("pca", &e))?;
        let flat: BTreeMap<String, String> = models
            .iter()
            .filter(|m| m.variant == reprise_artifact::pca::SCALED && m.d() < GPLVM_Q)
            .map(|m| {
                let why = format!(
                    "moves in {} dimension(s) (its PCA keeps d = {}), fewer than the GPLVM's q = {GPLVM_Q}",
                    m.d(),
                    m.d()
                );
                (m.label.clone(), why)
            })
            .collect();
        for (label, why) in flat {
            thin.entry(label).or_insert(why);
        }
        Ok(thin)
    }

    /// The segments the last label run wrote.
    pub(crate) fn segments(&self) -> Result<Vec<Segment>> {
        reprise_artifact::segments::read(&self.file("segments.parquet"))
            .map_err(|e| Error::Init(format!("reading what label wrote: {e}")))
    }
}
