//! Every artifact opens in pyarrow and in polars (Python), with its provenance keys.
//! Skips, saying so, where Python lacks either package (CI installs both: `.ci/run`).

use std::process::Command;

use crate::util::Project;

const SCRIPT: &str = r#"
import sys, glob, json
import pyarrow.parquet as pq
import polars as pl
files = sorted(glob.glob(sys.argv[1] + "/*.parquet"))
assert len(files) >= 5, files
for f in files:
    meta = pq.read_metadata(f).metadata
    keys = {k.decode(): v.decode() for k, v in meta.items()}
    for k in ["reprise.schema", "reprise.schema_version", "reprise.stage", "reprise.stage_version", "reprise.params_hash", "reprise.inputs"]:
        assert k in keys, (f, k)
    json.loads(keys["reprise.params"])
    t = pq.read_table(f)
    df = pl.read_parquet(f)
    assert df.shape == (t.num_rows, t.num_columns), (f, df.shape)
    print(f.split("/")[-1], df.shape, keys["reprise.stage"])
"#;

fn python_has(modules: &str) -> bool {
    Command::new("python3").args(["-c", &format!("import {modules}")]).output().is_ok_and(|o| o.status.success())
}

#[test]
fn artifacts_open_in_pyarrow_and_polars() {
    if !python_has("pyarrow, polars") {
        eprintln!(
            "SKIPPED artifacts_open_in_pyarrow_and_polars: python3 lacks pyarrow or polars (`.ci/run` installs them)"
        );
        assert!(std::env::var_os("CI").is_none(), "CI must have pyarrow and polars");
        return;
    }
    let p = Project::dragon_face();
    p.reprise(&["run"]).ok();
    let out = Command::new("python3")
        .args(["-c", SCRIPT, p.path("artifacts/dragon-face").to_str().unwrap()])
        .output()
        .unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{text}");
    assert!(text.contains("labeled_frames.parquet"), "{text}");
}
