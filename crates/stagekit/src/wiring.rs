//! What a stage reads and writes, declared by the stage in code, so that `pipeline.toml`
//! need only name the stages, their parameters and the user's own files: the runner gives
//! every output its default place in the pipeline's artifacts (or reports) directory and
//! wires every input to the one stage of the pipeline that writes the same artifact.
//!
//! An artifact is named by its file name (`pca_coords.parquet`): the kind and the role
//! together (`answers_reprise.parquet` and `answers_motion_graphs.parquet` are one kind in two
//! roles). A role is the stage's flag (`--coords`), as in `inputs.coords = "…"`.

/// A stage's declaration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wiring {
    /// The stage's usual name in `pipeline.toml` (`[stage.gplvm]`): a stage table of this
    /// name without `bin` runs [`Wiring::bin`].
    pub stage: &'static str,
    /// The binary (`reprise-gplvm`).
    pub bin: &'static str,
    /// What it reads.
    pub inputs: &'static [Input],
    /// What it writes.
    pub outputs: &'static [Output],
    /// Parameters the runner fills in from the pipeline unless `pipeline.toml` sets them.
    pub derived: &'static [(&'static str, Derived)],
    /// Whether the runner may run the stage one label at a time.
    pub partition: Partition,
}

/// How the runner may split a stage's work.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Partition {
    /// One run for everything.
    Whole,
    /// One run per label of the input `by` (a role with a `label` column, in the order its
    /// labels first appear). The stage takes `--partition <label>`, reads its whole inputs,
    /// and writes only that label's rows, each output with a `label` column; its rows for a
    /// label depend only on that label's rows of every labeled input (and on the whole of
    /// every input without a `label` column). The runner caches each label on exactly that
    /// and merges the labels' rows into the declared outputs
    /// (`reprise_artifact::partition::merge`).
    Label {
        /// The input whose labels are the partitions, and whose `segment_id`s are current.
        by: &'static str,
    },
    /// One run per ordered pair of two labels of the input `by`. The stage takes
    /// `--partition <from> --partition-to <to>` and writes only that pair's rows, each
    /// output with `from` and `to` columns; its rows depend only on the two labels' rows
    /// of every labeled input (and the whole of every input without a `label` column).
    LabelPair {
        /// The input whose labels make the pairs.
        by: &'static str,
    },
}

/// The `--partition` flag's name, as the runner passes it.
pub const PARTITION_FLAG: &str = "partition";
/// The `--partition-to` flag's name (a pair's second label).
pub const PARTITION_TO_FLAG: &str = "partition_to";

/// The items of one partition: with `partition` given, those whose label it is (an
/// input error naming `source` when there are none), else all of them.
pub fn only_partition<T>(
    items: Vec<T>,
    label_of: impl Fn(&T) -> &str,
    partition: Option<&str>,
    source: &std::path::Path,
) -> crate::StageResult<Vec<T>> {
    let Some(wanted) = partition else { return Ok(items) };
    let mut labels: Vec<String> = Vec::new();
    for item in &items {
        if !labels.iter().any(|l| l == label_of(item)) {
            labels.push(label_of(item).to_string());
        }
    }
    let kept: Vec<T> = items.into_iter().filter(|item| label_of(item) == wanted).collect();
    if kept.is_empty() {
        return Err(crate::StageError::Input(format!(
            "{}: no label `{wanted}` to fit for --partition (labels: {})",
            source.display(),
            labels.join(", ")
        )));
    }
    Ok(kept)
}

/// One input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Input {
    /// The flag's name with `_` (`labeled_frames`).
    pub role: &'static str,
    /// The artifact it reads (`labeled_frames.parquet`); for a source, what it is.
    pub artifact: &'static str,
    /// Whether it must be wired, and from where.
    pub need: Need,
}

/// How an input is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Need {
    /// Written by another stage of the pipeline; an error if none does.
    Required,
    /// Wired when another stage writes it, else left out.
    Optional,
    /// The user's own file (a character, a labels file, scripts): given in
    /// `pipeline.toml`, never wired; an error if missing.
    Source,
    /// A user's file that may be left out (one of several alternatives).
    OptionalSource,
}

/// One output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Output {
    /// The flag's name with `_` (`models`).
    pub role: &'static str,
    /// The file it writes by default (`gplvm_models.parquet`).
    pub artifact: &'static str,
    /// Which directory holds it.
    pub place: Place,
}

/// Where an output goes by default.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// `<artifacts>/` (the pipeline's `artifacts`, default `artifacts/<name>`).
    Artifacts,
    /// The pipeline's reports directory (`[pipeline] reports`, default `reports/<name>`).
    Reports,
}

/// A parameter the pipeline determines.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Derived {
    /// `[pipeline] name`.
    PipelineName,
    /// The path of the pipeline's lock file.
    LockFile,
}

/// `(role, artifact)` inputs written by other stages.
pub const fn required(role: &'static str, artifact: &'static str) -> Input {
    Input { role, artifact, need: Need::Required }
}

/// An input wired when some stage writes it.
pub const fn optional(role: &'static str, artifact: &'static str) -> Input {
    Input { role, artifact, need: Need::Optional }
}

/// A user's file.
pub const fn source(role: &'static str, what: &'static str) -> Input {
    Input { role, artifact: what, need: Need::Source }
}

/// A user's file that may be left out.
pub const fn optional_source(role: &'static str, what: &'static str) -> Input {
    Input { role, artifact: what, need: Need::OptionalSource }
}

/// A user's files given by a repeated flag (none, one or many).
pub const fn sources(role: &'static str, what: &'static str) -> Input {
    optional_source(role, what)
}

/// An output in the artifacts directory.
pub const fn artifact(role: &'static str, file: &'static str) -> Output {
    Output { role, artifact: file, place: Place::Artifacts }
}

/// An output in the reports directory.
pub const fn report(role: &'static str, file: &'static str) -> Output {
    Output { role, artifact: file, place: Place::Reports }
}

/// Declares a stage's files once: from one table it makes
///
/// - `pub struct Io`, the stage's file flags (`--labeled-frames FILE`) and the flags the
///   runner passes (`--partition LABEL` and `--partition-to LABEL` as the partition
///   allows, `--check`), to be flattened into the stage's `Args` with
///   `#[command(flatten)] #[serde(skip)] pub io: Io` (so none is a parameter);
/// - `pub const WIRING`, the declaration the runner wires pipelines by ([`Wiring`]);
/// - `Io::inputs`, every given input by role, which `Io::provenance` records, so the
///   role an artifact's provenance names is the flag it was given with.
///
/// An input is `required`, `optional` (`Option<PathBuf>`), `source`, `optional_source`
/// (`Option<PathBuf>`) or `sources` (`Vec<PathBuf>`, the flag repeated; recorded as
/// `role` for one file, `role[i]` for several); an output is `artifact` or `report`. Doc
/// comments become the flags' help.
///
/// ```ignore
/// reprise_stagekit::stage_io! {
///     stage: "pca", bin: "reprise-pca",
///     partition: Label { by: "labeled_frames" },
///     derived: [],
///     inputs {
///         /// Input: the labeled frames.
///         labeled_frames: required "labeled_frames.parquet",
///     }
///     outputs {
///         /// Output: the PCA models.
///         models: artifact "pca_models.parquet",
///     }
/// }
/// ```
#[macro_export]
macro_rules! stage_io {
    (
        stage: $stage:literal, bin: $bin:literal,
        partition: $partition:ident $({ by: $by:literal })?,
        derived: [$(($dname:literal, $derived:ident)),* $(,)?],
        inputs { $( $(#[$imeta:meta])* $irole:ident : $need:ident $iart:literal ),* $(,)? }
        outputs { $( $(#[$ometa:meta])* $orole:ident : $place:ident $oart:literal ),* $(,)? }
    ) => {
        $crate::stage_io!(@runs $partition
            [$( $(#[$ometa])* #[arg(long, value_name = "FILE")] pub $orole: std::path::PathBuf, )*]
            $( $(#[$imeta])* $irole : $need $iart, )*
        );

        /// What the stage reads and writes, for the runner's wiring.
        pub const WIRING: $crate::wiring::Wiring = $crate::wiring::Wiring {
            stage: $stage,
            bin: $bin,
            inputs: &[$($crate::wiring::$need(stringify!($irole), $iart)),*],
            outputs: &[$($crate::wiring::$place(stringify!($orole), $oart)),*],
            derived: &[$(($dname, $crate::wiring::Derived::$derived)),*],
            partition: $crate::wiring::Partition::$partition $({ by: $by })?,
        };

        impl Io {
            /// Every input given, by role, in declaration order.
            pub fn inputs(&self) -> Vec<(String, &std::path::Path)> {
                let mut given = Vec::new();
                $( $crate::wiring::Given::given(&self.$irole, stringify!($irole), &mut given); )*
                given
            }

            /// The stage's provenance record: its name and crate version, `params` (its
            /// parameters; the file flags are `#[serde(skip)]`) and every given input's
            /// path and content hash, by role.
            pub fn provenance(
                &self,
                params: &impl $crate::serde::Serialize,
            ) -> $crate::StageResult<$crate::Provenance> {
                let record = $crate::provenance(WIRING.stage, env!("CARGO_PKG_VERSION"), params);
                self.inputs().into_iter().try_fold(record, |p, (role, path)| Ok(p.with_input(&role, path)?))
            }
        }
    };
    // After the outputs: the flags of a partitioned run (as the runner passes them) and
    // `--check`.
    (@runs Whole [$($o:tt)*] $($inputs:tt)*) => {
        $crate::stage_io!(@io [] [$($o)*
            /// Only validate the flags and exit.
            #[arg(long)]
            pub check: bool,
        ] $($inputs)*);
    };
    (@runs Label [$($o:tt)*] $($inputs:tt)*) => {
        $crate::stage_io!(@io [] [$($o)*
            /// Only this label (the runner's partitioned run): its rows only are written.
            #[arg(long, value_name = "LABEL")]
            pub partition: Option<String>,
            /// Only validate the flags and exit.
            #[arg(long)]
            pub check: bool,
        ] $($inputs)*);
    };
    (@runs LabelPair [$($o:tt)*] $($inputs:tt)*) => {
        $crate::stage_io!(@io [] [$($o)*
            /// Only the pair from this label (the runner's partitioned run), to `--partition-to`.
            #[arg(long, value_name = "LABEL", requires = "partition_to")]
            pub partition: Option<String>,
            /// Only the pair to this label (with `--partition`).
            #[arg(long, value_name = "LABEL", requires = "partition")]
            pub partition_to: Option<String>,
            /// Only validate the flags and exit.
            #[arg(long)]
            pub check: bool,
        ] $($inputs)*);
    };
    // The struct is built field by field: clap's derive reads a field's type as written,
    // so `Option<PathBuf>` must appear literally to make the flag optional.
    (@io [$($fields:tt)*] [$($outputs:tt)*]) => {
        /// The stage's files (declared once, with [`WIRING`], by
        /// [`reprise_stagekit::stage_io!`]).
        #[derive(Debug, Clone, clap::Args)]
        pub struct Io {
            $($fields)*
            $($outputs)*
        }
    };
    (@io [$($f:tt)*] $o:tt $(#[$m:meta])* $role:ident : required $art:literal, $($rest:tt)*) => {
        $crate::stage_io!(@io [$($f)* $(#[$m])* #[arg(long, value_name = "FILE")] pub $role: std::path::PathBuf,] $o $($rest)*);
    };
    (@io [$($f:tt)*] $o:tt $(#[$m:meta])* $role:ident : source $art:literal, $($rest:tt)*) => {
        $crate::stage_io!(@io [$($f)* $(#[$m])* #[arg(long, value_name = "FILE")] pub $role: std::path::PathBuf,] $o $($rest)*);
    };
    (@io [$($f:tt)*] $o:tt $(#[$m:meta])* $role:ident : optional $art:literal, $($rest:tt)*) => {
        $crate::stage_io!(@io [$($f)* $(#[$m])* #[arg(long, value_name = "FILE")] pub $role: Option<std::path::PathBuf>,] $o $($rest)*);
    };
    (@io [$($f:tt)*] $o:tt $(#[$m:meta])* $role:ident : optional_source $art:literal, $($rest:tt)*) => {
        $crate::stage_io!(@io [$($f)* $(#[$m])* #[arg(long, value_name = "FILE")] pub $role: Option<std::path::PathBuf>,] $o $($rest)*);
    };
    (@io [$($f:tt)*] $o:tt $(#[$m:meta])* $role:ident : sources $art:literal, $($rest:tt)*) => {
        $crate::stage_io!(@io [$($f)* $(#[$m])* #[arg(long, value_name = "FILE")] pub $role: Vec<std::path::PathBuf>,] $o $($rest)*);
    };
}

/// An input field's given paths, by role (see [`stage_io!`]).
pub trait Given {
    /// Appends `(role, path)` for each path given.
    fn given<'a>(&'a self, role: &str, out: &mut Vec<(String, &'a std::path::Path)>);
}

impl Given for std::path::PathBuf {
    fn given<'a>(&'a self, role: &str, out: &mut Vec<(String, &'a std::path::Path)>) {
        out.push((role.to_string(), self));
    }
}

impl Given for Option<std::path::PathBuf> {
    fn given<'a>(&'a self, role: &str, out: &mut Vec<(String, &'a std::path::Path)>) {
        if let Some(p) = self {
            out.push((role.to_string(), p));
        }
    }
}

impl Given for Vec<std::path::PathBuf> {
    fn given<'a>(&'a self, role: &str, out: &mut Vec<(String, &'a std::path::Path)>) {
        match self.as_slice() {
            [one] => out.push((role.to_string(), one)),
            many => out.extend(many.iter().enumerate().map(|(i, p)| (format!("{role}[{i}]"), p.as_path()))),
        }
    }
}

/// Where a stage's command line and its declaration disagree: every declared input and
/// output must be a flag taking a `FILE`, and every flag taking a `FILE` must be declared
/// (or be a [`Derived`] parameter). Empty when they agree.
pub fn disagreements(wiring: &Wiring, command: &clap::Command) -> Vec<String> {
    let declared: Vec<&str> =
        wiring.inputs.iter().map(|i| i.role).chain(wiring.outputs.iter().map(|o| o.role)).collect();
    let mut out = Vec::new();
    for role in &declared {
        match command.get_arguments().find(|a| a.get_id() == *role) {
            None => out.push(format!("{}: declared `{role}` has no flag", wiring.stage)),
            Some(a) if a.get_long() != Some(&role.replace('_', "-")) => {
                out.push(format!("{}: `{role}` is not the flag --{}", wiring.stage, role.replace('_', "-")))
            }
            Some(_) => {}
        }
    }
    let files = command
        .get_arguments()
        .filter(|a| a.get_value_names().is_some_and(|names| names.iter().any(|n| n.as_str() == "FILE")));
    for a in files {
        let id = a.get_id().as_str();
        if !declared.contains(&id) && !wiring.derived.iter().any(|(name, _)| *name == id) {
            out.push(format!("{}: flag --{} takes a FILE but is not declared", wiring.stage, id.replace('_', "-")));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// A partition keeps its label's items in order; no partition keeps all; an unknown
    /// label is an input error listing the labels.
    #[test]
    fn only_partition_keeps_one_label() {
        let items = vec![("a", 1), ("b", 2), ("a", 3)];
        let f = Path::new("f.parquet");
        assert_eq!(super::only_partition(items.clone(), |i| i.0, Some("a"), f).unwrap(), [("a", 1), ("a", 3)]);
        assert_eq!(super::only_partition(items.clone(), |i| i.0, None, f).unwrap(), items);
        let e = super::only_partition(items, |i| i.0, Some("c"), f).unwrap_err();
        assert_eq!(e.code(), crate::exit::INPUT);
        assert!(e.to_string().contains("f.parquet: no label `c`") && e.to_string().contains("(labels: a, b)"), "{e}");
    }
}
