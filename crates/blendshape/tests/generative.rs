//! Generative tests of the blendshape zip reader: zips whose neutral and shape OBJs are
//! mutated valid meshes or token soup read to a face or a `BlendshapeError` — never a
//! panic, an allocation sized by a typo, or a hang — and a face that reads evaluates.

use std::io::Write;

use reprise_blendshape::Blendshapes;
use reprise_fuzzkit::proptest::prelude::*;
use reprise_fuzzkit::{config, mutated_text, token_soup, within, LIMIT};

/// A valid quad mesh.
const GOOD: &str =
    "# quad\no Neutral\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1 4/1/1\n";

/// The format's own words.
const TOKENS: &[&str] = &[
    "v",
    "vn",
    "vt",
    "f",
    "o",
    "g",
    "s",
    "usemtl",
    "#",
    "1",
    "-1",
    "0",
    "4",
    "1/1/1",
    "2//1",
    "-5",
    "1e308",
    "nan",
    "inf",
    "99999999999999999999",
    "-1e308",
    "v 1e308 1e308 1e308\n",
    "v -1e308 -1e308 -1e308\n",
    "\n",
    " ",
    "\t",
    "\r\n",
    "v 0 0 0\n",
    "f 1 2 3\n",
    "f 1 2\n",
];

fn zip_of(neutral: &str, shape: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("face.zip");
    let mut w = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
    for (name, text) in [("face/Neutral.obj", neutral), ("face/smile.obj", shape)] {
        w.start_file(name, zip::write::SimpleFileOptions::default()).unwrap();
        w.write_all(text.as_bytes()).unwrap();
    }
    w.finish().unwrap();
    (dir, path)
}

/// Reads the zip; an error names the file; a face evaluates at weight 1.
fn read(neutral: String, shape: String) {
    within(LIMIT, move || {
        let (_dir, path) = zip_of(&neutral, &shape);
        match Blendshapes::read_zip(&path) {
            Ok(face) => {
                let mut out = vec![0.0; 3 * face.vertex_count()];
                face.evaluate(&[1.0], &mut out);
                assert!(out.iter().all(|v| v.is_finite()), "a face that reads evaluates to finite positions");
            }
            Err(e) => assert!(e.to_string().contains("face.zip"), "{e}"),
        }
    });
}

proptest! {
    #![proptest_config(config(200))]

    #[test]
    fn mutated_meshes_read_or_fail_cleanly(neutral in mutated_text(GOOD, TOKENS), shape in mutated_text(GOOD, TOKENS)) {
        read(neutral, shape);
    }

    #[test]
    fn token_soup_reads_or_fails_cleanly(body in token_soup(TOKENS)) {
        read(GOOD.to_string(), body.clone());
        read(body, GOOD.to_string());
    }
}
