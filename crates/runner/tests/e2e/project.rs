//! A throwaway pipeline project: four shell-script stages in a tempdir,
//!
//! ```text
//! data/src.txt -> a -> art/a.txt -> b -> art/b.txt -> c -> art/c.txt
//! data/other.txt -> d -> art/d.txt
//! ```
//!
//! Each script logs its name to `runs.log` when it runs and to `checks.log` when invoked
//! with `--check`, writes every input's content plus its name and parameters to each
//! output, and misbehaves on demand through its `mode` parameter: `fail` (exit 7), `crash`
//! (`kill -9 $$`), `nowrite` (exit 0 without writing) or `badcheck` (reject `--check`).

use std::ffi::OsString;
use std::fs;
use std::os::unix::fs::PermissionsExt;
use std::path::PathBuf;

use reprise_runner::main_with_io;

const STAGE_SCRIPT: &str = r#"#!/bin/sh
# A test stage (see tests/e2e/project.rs).
name=$(basename "$0" .sh)
name=${name#stage_}
check=0 inputs= outputs= params= mode=ok
while [ $# -gt 0 ]; do
  case "$1" in
    --check) check=1; shift ;;
    --in*) inputs="$inputs $2"; shift 2 ;;
    --out*) outputs="$outputs $2"; shift 2 ;;
    --mode) mode=$2; params="$params mode=$2"; shift 2 ;;
    --*=*) params="$params ${1#--}"; shift ;;
    --*) params="$params ${1#--}=$2"; shift 2 ;;
    *) echo "stage $name: error: unexpected argument $1" >&2; exit 2 ;;
  esac
done
if [ "$check" = 1 ]; then
  echo "$name" >> checks.log
  if [ "$mode" = badcheck ]; then
    echo "stage $name: error: --mode badcheck is not a valid mode" >&2
    exit 2
  fi
  exit 0
fi
echo "$name" >> runs.log
case "$mode" in
  fail) echo "stage $name: error: failing on purpose" >&2; exit 7 ;;
  crash) kill -9 $$ ;;
  nowrite) exit 0 ;;
esac
for out in $outputs; do
  { for f in $inputs; do cat "$f"; done; echo "$name$params"; } > "$out.tmp" && mv "$out.tmp" "$out"
done
"#;

/// The pipeline every test starts from.
pub const PIPELINE: &str = r#"
[pipeline]
name = "test"
artifacts = "art"

[stage.a]
bin = "./stage_a.sh"
inputs.in_src = "data/src.txt"
outputs.out = "art/a.txt"
params.mode = "ok"
params.k = 1

[stage.b]
bin = "./stage_b.sh"
inputs.in_a = "art/a.txt"
outputs.out = "art/b.txt"
params.mode = "ok"
params.k = 1
params.shift = -0.5

[stage.c]
bin = "./stage_c.sh"
inputs.in_b = "./art/b.txt"
outputs.out = "art/c.txt"
params.mode = "ok"
params.tags = ["x", "y"]

[stage.d]
bin = "./stage_d.sh"
inputs.in_src = "data/other.txt"
outputs.out = "art/d.txt"
params.mode = "ok"
"#;

/// What one `reprise` invocation did.
pub struct Outcome {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

/// A pipeline project in a tempdir.
pub struct Project {
    dir: tempfile::TempDir,
}

impl Project {
    /// Writes the scripts, the source data and [`PIPELINE`].
    pub fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let project = Self { dir };
        for stage in ["a", "b", "c", "d"] {
            project.write_script(&format!("stage_{stage}.sh"), STAGE_SCRIPT);
        }
        project.write("data/src.txt", "source\n");
        project.write("data/other.txt", "other\n");
        project.write("pipeline.toml", PIPELINE);
        project
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    pub fn write(&self, rel: &str, text: &str) {
        let path = self.path(rel);
        fs::create_dir_all(path.parent().unwrap()).unwrap();
        fs::write(path, text).unwrap();
    }

    pub fn write_script(&self, rel: &str, text: &str) {
        self.write(rel, text);
        fs::set_permissions(self.path(rel), fs::Permissions::from_mode(0o755)).unwrap();
    }

    pub fn read(&self, rel: &str) -> String {
        fs::read_to_string(self.path(rel)).unwrap()
    }

    /// Rewrites `pipeline.toml`, replacing `from` (which must occur) by `to`.
    pub fn edit_pipeline(&self, from: &str, to: &str) {
        let text = self.read("pipeline.toml");
        assert!(text.contains(from), "`{from}` is not in pipeline.toml");
        self.write("pipeline.toml", &text.replacen(from, to, 1));
    }

    /// Sets `params.mode` of `stage`.
    pub fn set_mode(&self, stage: &str, mode: &str) {
        let text = self.read("pipeline.toml");
        let start = text.find(&format!("[stage.{stage}]")).unwrap();
        let at = start + text[start..].find("params.mode = ").unwrap();
        let end = at + text[at..].find('\n').unwrap();
        self.write("pipeline.toml", &format!("{}params.mode = \"{mode}\"{}", &text[..at], &text[end..]));
    }

    /// `reprise <args…> --pipeline <this project's pipeline.toml>` through `main_with_io`.
    pub fn reprise(&self, args: &[&str]) -> Outcome {
        let (mut out, mut err) = (Vec::new(), Vec::new());
        let code = main_with_io(self.argv(args), reprise_runner::Commands::default(), &mut out, &mut err);
        Outcome { code, stdout: String::from_utf8(out).unwrap(), stderr: String::from_utf8(err).unwrap() }
    }

    /// The argument vector for `reprise <args…> --pipeline …`.
    pub fn argv(&self, args: &[&str]) -> Vec<OsString> {
        let mut argv: Vec<OsString> = vec!["reprise".into()];
        argv.extend(args.iter().map(OsString::from));
        argv.push("--pipeline".into());
        argv.push(self.path("pipeline.toml").into());
        argv
    }

    /// `reprise run …`, which must succeed.
    pub fn run_ok(&self, args: &[&str]) -> Outcome {
        let mut full = vec!["run"];
        full.extend_from_slice(args);
        let outcome = self.reprise(&full);
        assert_eq!(outcome.code, 0, "reprise run {args:?} failed:\n{}", outcome.stderr);
        outcome
    }

    /// `reprise status` output.
    pub fn status(&self) -> String {
        let outcome = self.reprise(&["status"]);
        assert_eq!(outcome.code, 0, "{}", outcome.stderr);
        outcome.stdout
    }

    /// The stages that ran since the last call (and forgets them).
    pub fn runs(&self) -> Vec<String> {
        take_lines(&self.path("runs.log"))
    }

    /// The stages invoked with `--check` since the last call (and forgets them).
    pub fn checks(&self) -> Vec<String> {
        take_lines(&self.path("checks.log"))
    }

    /// The lock file as JSON.
    pub fn lock(&self) -> serde_json::Value {
        serde_json::from_str(&self.read("art/reprise.lock")).unwrap()
    }

    /// The names of the stages the lock file records.
    pub fn locked(&self) -> Vec<String> {
        self.lock()["stages"].as_object().unwrap().keys().cloned().collect()
    }

    /// The block of `reprise status` about `stage`: its verdict line and reasons.
    pub fn status_of(&self, stage: &str) -> String {
        let status = self.status();
        let mut lines = status.lines().skip_while(|l| !l.trim_start().starts_with(&format!("{stage} ")));
        let mut block = vec![lines.next().unwrap_or_default().trim().to_string()];
        block.extend(lines.take_while(|l| l.trim_start().starts_with("- ")).map(|l| l.trim().to_string()));
        block.join("\n")
    }
}

fn take_lines(path: &std::path::Path) -> Vec<String> {
    let text = fs::read_to_string(path).unwrap_or_default();
    let _ = fs::remove_file(path);
    text.lines().map(str::to_string).collect()
}
