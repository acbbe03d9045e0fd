//! What every live character plays, loaded once from a pipeline's artifacts: the label
//! models and bridges (reprise), the motion graph, the motion-matching database, the
//! labeled frames they all index, and the rig that turns controls into a mesh.

use std::path::{Path, PathBuf};

use reprise_artifact::controls::Controls;
use reprise_artifact::frames::LabeledFrames;
use reprise_artifact::{motion_graph, scales};
use reprise_matching::ControllerSettings;
use reprise_model_library::matching::Corpus;
use reprise_model_library::LibraryParts;
use reprise_rig::{PoseLayout, Rig};
use reprise_stagekit::{StageError, StageResult};
use reprise_synth_engine::engine::{Library, Settings};
use reprise_synth_engine::method::Method;
use reprise_transition_graph::Graph;

/// The artifacts a world is loaded from (as the transitions and motion-match stages read
/// them), and the controls table naming the rig.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Paths {
    /// `gplvm_models.parquet`.
    pub gplvm_models: PathBuf,
    /// `gplvm_latents.parquet`.
    pub latents: PathBuf,
    /// `pca_models.parquet`.
    pub pca_models: PathBuf,
    /// `scales.parquet`.
    pub scales: PathBuf,
    /// `bridges.parquet`.
    pub bridges: PathBuf,
    /// `labeled_frames.parquet`.
    pub labeled_frames: PathBuf,
    /// `mg_nodes.parquet`.
    pub mg_nodes: PathBuf,
    /// `mg_edges.parquet`.
    pub mg_edges: PathBuf,
    /// `controls.parquet` (names the rig).
    pub controls: PathBuf,
}

impl Paths {
    /// The default file names in directory `dir` (a pipeline's artifact directory).
    pub fn in_dir(dir: &Path) -> Self {
        let f = |name: &str| dir.join(name);
        Self {
            gplvm_models: f("gplvm_models.parquet"),
            latents: f("gplvm_latents.parquet"),
            pca_models: f("pca_models.parquet"),
            scales: f("scales.parquet"),
            bridges: f("bridges.parquet"),
            labeled_frames: f("labeled_frames.parquet"),
            mg_nodes: f("mg_nodes.parquet"),
            mg_edges: f("mg_edges.parquet"),
            controls: f("controls.parquet"),
        }
    }
}

/// The systems' settings, as the benchmark's stages default them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuning {
    /// Motion matching's principal coordinates per feature time.
    pub features: usize,
    /// Motion matching's search timer and inertialization.
    pub controller: ControllerSettings,
    /// The crossfade's blend, frames.
    pub blend_frames: usize,
    /// Motion Graphs' path slack (a near-shortest path within 1 + slack of the fewest frames).
    pub path_slack: f64,
}

impl Default for Tuning {
    fn default() -> Self {
        Self { features: 8, controller: ControllerSettings::default(), blend_frames: 12, path_slack: 0.1 }
    }
}

/// Everything the characters play. Loaded once per process and never freed
/// ([`World::load`] leaks it): every session borrows it for as long as it runs.
pub struct World {
    /// Frames per second of the corpus (and of every system's output).
    pub fps: f64,
    /// Labels, in the label models' order (a frame's `label` indexes this).
    pub labels: Vec<String>,
    /// Control names, the order of every frame's controls.
    pub controls: Vec<String>,
    /// The labeled frames (rows index the motion graph's nodes and the database).
    pub labeled: LabeledFrames,
    /// Per labeled row, its label's index in [`World::labels`].
    pub row_label: Vec<usize>,
    /// Motion matching's database.
    pub corpus: Corpus,
    /// Per database label id, its index in [`World::labels`].
    pub corpus_label: Vec<usize>,
    /// The motion graph.
    pub graph: Graph,
    /// Its edges (`graph`'s edge ids index this).
    pub edges: Vec<motion_graph::Edge>,
    /// Nodes in the graph's largest strongly connected component.
    pub alive: Vec<bool>,
    /// The graph's blend length, frames.
    pub window: usize,
    /// reprise's engine library under the tuned method.
    pub tuned: Library<'static>,
    /// reprise's engine library under the paper's method.
    pub paper: Library<'static>,
    /// The engine settings of the tuned method.
    pub tuned_settings: Settings,
    /// The engine settings of the paper's method.
    pub paper_settings: Settings,
    /// The systems' settings.
    pub tuning: Tuning,
    /// The rig and the layout of the frames' controls in it.
    pub rig: (Box<dyn Rig>, PoseLayout),
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World").field("labels", &self.labels).field("fps", &self.fps).finish_non_exhaustive()
    }
}

impl World {
    /// Loads the artifacts at `paths` (the rig's relative paths resolve against the current
    /// directory, as in every stage) and leaks the result.
    ///
    /// # Errors
    /// [`StageError::Input`] naming the file when an artifact is missing, malformed, or
    /// belongs to another run than the others.
    pub fn load(paths: &Paths, tuning: Tuning) -> StageResult<&'static World> {
        let parts: &'static LibraryParts = Box::leak(Box::new(LibraryParts::load(
            &paths.gplvm_models,
            &paths.latents,
            &paths.pca_models,
            &paths.scales,
            &paths.bridges,
        )?));
        let labeled = LabeledFrames::read(&paths.labeled_frames)?;
        if labeled.frames.controls != parts.models.controls {
            return Err(StageError::Input(format!(
                "{} and {} list different controls; rerun the stages after label",
                paths.labeled_frames.display(),
                paths.gplvm_models.display()
            )));
        }
        let mg = motion_graph::read_graph(&paths.mg_nodes, &paths.mg_edges)?;
        mg.check_frames(&labeled, &paths.labeled_frames)?;
        let graph = Graph::from_edges(mg.nodes.frame.len(), mg.edges.iter().map(|e| (e.from, e.to, e.cost)))
            .map_err(|e| StageError::Input(format!("{}: {e}", paths.mg_edges.display())))?;
        let weight = scales::mean_weights(&scales::read(&paths.scales)?, &labeled.frames.controls);
        let corpus = Corpus::build(&labeled, &paths.labeled_frames, &paths.scales, weight, tuning.features)?;
        let labels: Vec<String> = parts.models.models.iter().map(|m| m.label.clone()).collect();
        let index = |l: &str, file: &Path| {
            labels
                .iter()
                .position(|x| x == l)
                .ok_or_else(|| StageError::Input(format!("{}: label `{l}` has no model; rerun gplvm", file.display())))
        };
        let row_label = labeled.label.iter().map(|l| index(l, &paths.labeled_frames)).collect::<StageResult<_>>()?;
        let corpus_label = corpus.labels.iter().map(|l| index(l, &paths.labeled_frames)).collect::<StageResult<_>>()?;
        let rig = reprise_stagekit::rig::open_rig(&Controls::read(&paths.controls)?, &labeled.frames.controls)?;
        let fps = labeled.frames.fps;
        let tuned_settings = Settings { fps, ..Settings::default() };
        let paper_settings = Settings { fps, method: Method::PAPER, ..Settings::default() };
        Ok(Box::leak(Box::new(World {
            fps,
            controls: labeled.frames.controls.clone(),
            labels,
            row_label,
            corpus,
            corpus_label,
            alive: mg.nodes.in_scc.clone(),
            window: mg.window,
            edges: mg.edges,
            graph,
            labeled,
            tuned: parts.library(&tuned_settings),
            paper: parts.library(&paper_settings),
            tuned_settings,
            paper_settings,
            tuning,
            rig,
        })))
    }

    /// The index of label `name`.
    pub fn label_index(&self, name: &str) -> Option<usize> {
        self.labels.iter().position(|l| l == name)
    }

    /// The row a session of every system starting in `label` starts at: the label's first
    /// labeled frame that is in the motion graph's component and has a next frame in its
    /// take.
    pub fn start_row(&self, label: usize) -> Option<usize> {
        self.start_row_for(label, true)
    }

    /// [`World::start_row`] for a session with Motion Graphs (`with_graph`) or without it:
    /// without, any labeled frame of the label with a next frame in its take (a character
    /// whose motion graph has no strongly connected component to speak of can still run
    /// the other systems).
    pub fn start_row_for(&self, label: usize, with_graph: bool) -> Option<usize> {
        let db = &self.corpus.db;
        (0..self.labeled.frames.rows())
            .find(|&r| self.row_label[r] == label && (self.alive[r] || !with_graph) && db.has_next(r))
    }

    /// The first labeled row of the take of label `label` named by `segment` id and/or
    /// `clip` name (a PLAY command's take), if it has one.
    pub fn take_start(&self, label: usize, segment: Option<i64>, clip: Option<&str>) -> Option<usize> {
        let l = &self.labeled;
        (0..l.frames.rows()).find(|&r| {
            self.row_label[r] == label
                && segment.is_none_or(|s| s == l.segment_id[r])
                && clip.is_none_or(|c| c == l.frames.clip[r])
        })
    }

    /// The rig's mesh of `controls` (one frame), `3 × vertices` values.
    ///
    /// # Errors
    /// [`StageError::Input`] if the rig fails.
    pub fn mesh(&self, controls: &[f64]) -> StageResult<Vec<f64>> {
        reprise_stagekit::rig::meshes(&self.rig, std::slice::from_ref(&controls.to_vec()))
    }
}
