//! Blendshape faces from a zip of Wavefront OBJ meshes: `Neutral.obj` and one mesh per
//! shape, every one with the same vertices in the same order (the ARKit reference shapes of
//! `../shared/datasets/arkit_blendshapes/`). The face at weights $w$ is
//! $$x(w) = x_0 + \sum_i w_i\,(x_i - x_0),$$
//! $x_0$ the neutral mesh and $x_i$ shape $i$'s, in the meshes' length unit.
//!
//! Only what a face rig needs is read from an OBJ: `v x y z` vertices and `f` faces
//! (`a`, `a/t`, `a//n`, `a/t/n`, negative indices relative to the end; polygons are split
//! into a fan of triangles). Everything else (normals, texture coordinates, groups,
//! materials) is skipped.
#![warn(missing_docs)]

use std::io::Read;
use std::path::Path;

/// Most OBJ entries a zip may hold.
pub const MAX_ENTRIES: usize = 1024;
/// Most uncompressed bytes of one OBJ entry.
pub const MAX_ENTRY_BYTES: u64 = 64 << 20;
/// Most vertices of one mesh.
pub const MAX_VERTICES: usize = 1 << 20;

/// Why a blendshape zip cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum BlendshapeError {
    /// The zip itself.
    #[error("{path}: {message}")]
    Zip {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// One OBJ entry, with its line where there is one.
    #[error("{path}: {entry}{}: {message}", line.map(|l| format!(", line {l}")).unwrap_or_default())]
    Obj {
        /// The zip.
        path: String,
        /// The entry.
        entry: String,
        /// The line, 1-based.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
}

/// A neutral mesh and its shapes' deltas.
#[derive(Debug, Clone, PartialEq)]
pub struct Blendshapes {
    /// Shape names (the entries' file stems), in name order: the weights' order.
    pub names: Vec<String>,
    /// The neutral mesh, `x, y, z` per vertex.
    pub neutral: Vec<f64>,
    /// Per shape, its mesh minus the neutral (`3V` values each), shape-major.
    pub deltas: Vec<f64>,
    /// The neutral mesh's triangles.
    pub triangles: Vec<[u32; 3]>,
}

impl Blendshapes {
    /// Vertices per mesh.
    pub fn vertex_count(&self) -> usize {
        self.neutral.len() / 3
    }

    /// The face at `weights` (one per shape) into `out` (`3V` values).
    ///
    /// # Panics
    /// If `weights` or `out` have the wrong length (callers check batch shapes).
    pub fn evaluate(&self, weights: &[f64], out: &mut [f64]) {
        assert_eq!(weights.len(), self.names.len(), "one weight per shape");
        out.copy_from_slice(&self.neutral);
        let m = self.neutral.len();
        for (w, delta) in weights.iter().zip(self.deltas.chunks_exact(m)) {
            if *w != 0.0 {
                for (o, d) in out.iter_mut().zip(delta) {
                    *o += w * d;
                }
            }
        }
    }

    /// Reads the zip at `path`: the entry whose file stem is `Neutral` (any case) is the
    /// neutral mesh, every other `.obj` entry a shape named by its stem.
    ///
    /// # Errors
    /// An unreadable zip; no neutral, two shapes of one name, more than [`MAX_ENTRIES`]
    /// meshes; an entry larger than [`MAX_ENTRY_BYTES`], an OBJ line that cannot be read
    /// (named with its line), a shape whose vertex count differs from the neutral's.
    pub fn read_zip(path: &Path) -> Result<Self, BlendshapeError> {
        let shown = path.display().to_string();
        let zip_err = |message: String| BlendshapeError::Zip { path: shown.clone(), message };
        let file = std::fs::File::open(path).map_err(|e| zip_err(e.to_string()))?;
        let mut archive = zip::ZipArchive::new(file).map_err(|e| zip_err(format!("not a readable zip: {e}")))?;
        let mut neutral: Option<(String, Mesh)> = None;
        let mut shapes: Vec<(String, String, Mesh)> = Vec::new();
        for i in 0..archive.len() {
            let mut entry = archive.by_index(i).map_err(|e| zip_err(format!("entry {i}: {e}")))?;
            let name = entry.name().to_string();
            let Some(stem) = obj_stem(&name) else { continue };
            if shapes.len() >= MAX_ENTRIES {
                return Err(zip_err(format!("more than {MAX_ENTRIES} OBJ meshes")));
            }
            if entry.size() > MAX_ENTRY_BYTES {
                return Err(zip_err(format!("{name}: {} bytes, more than {MAX_ENTRY_BYTES}", entry.size())));
            }
            let mut text = String::new();
            (&mut entry)
                .take(MAX_ENTRY_BYTES + 1)
                .read_to_string(&mut text)
                .map_err(|e| zip_err(format!("{name}: {e}")))?;
            let mesh = parse_obj(&text).map_err(|(line, message)| BlendshapeError::Obj {
                path: shown.clone(),
                entry: name.clone(),
                line,
                message,
            })?;
            if stem.eq_ignore_ascii_case("neutral") {
                if neutral.is_some() {
                    return Err(zip_err(format!("two neutral meshes (the second is {name})")));
                }
                neutral = Some((name, mesh));
            } else {
                shapes.push((stem, name, mesh));
            }
        }
        let (_, neutral) = neutral.ok_or_else(|| zip_err("no Neutral.obj: the neutral mesh is needed".into()))?;
        shapes.sort_by(|a, b| a.0.cmp(&b.0));
        if let Some(w) = shapes.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(zip_err(format!("two shapes named `{}` ({} and {})", w[0].0, w[0].1, w[1].1)));
        }
        if shapes.is_empty() {
            return Err(zip_err("no shape besides the neutral mesh".into()));
        }
        let mut deltas = Vec::with_capacity(shapes.len() * neutral.positions.len());
        for (_, entry, mesh) in &shapes {
            if mesh.positions.len() != neutral.positions.len() {
                return Err(BlendshapeError::Obj {
                    path: shown.clone(),
                    entry: entry.clone(),
                    line: None,
                    message: format!(
                        "{} vertices where the neutral mesh has {}; every shape must have the neutral's vertices in its order",
                        mesh.positions.len() / 3,
                        neutral.positions.len() / 3
                    ),
                });
            }
            let start = deltas.len();
            deltas.extend(mesh.positions.iter().zip(&neutral.positions).map(|(s, n)| s - n));
            if let Some(i) = deltas[start..].iter().position(|d| !d.is_finite()) {
                return Err(BlendshapeError::Obj {
                    path: shown.clone(),
                    entry: entry.clone(),
                    line: None,
                    message: format!("vertex {} moves by more than a number can hold from the neutral mesh", i / 3 + 1),
                });
            }
        }
        Ok(Self {
            names: shapes.into_iter().map(|s| s.0).collect(),
            neutral: neutral.positions,
            deltas,
            triangles: neutral.triangles,
        })
    }
}

/// The file stem of an `.obj` entry (not a directory, not a hidden file).
fn obj_stem(name: &str) -> Option<String> {
    let file = name.rsplit('/').next()?;
    let stem = file.strip_suffix(".obj").or_else(|| file.strip_suffix(".OBJ"))?;
    (!stem.is_empty() && !stem.starts_with('.')).then(|| stem.to_string())
}

/// An OBJ's vertices and triangles.
#[derive(Debug, Clone, PartialEq)]
struct Mesh {
    positions: Vec<f64>,
    triangles: Vec<[u32; 3]>,
}

/// Parses the vertices and faces of an OBJ; an error is `(line, message)`.
fn parse_obj(text: &str) -> Result<Mesh, (Option<usize>, String)> {
    let mut positions = Vec::new();
    let mut faces: Vec<(usize, Vec<i64>)> = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let xyz: Vec<f64> = words
                    .take(3)
                    .map(str::parse::<f64>)
                    .collect::<Result<_, _>>()
                    .map_err(|e| (Some(k + 1), format!("a vertex needs three numbers: {e}")))?;
                if xyz.len() != 3 || xyz.iter().any(|v| !v.is_finite()) {
                    return Err((Some(k + 1), "a vertex needs three finite numbers".into()));
                }
                if positions.len() / 3 >= MAX_VERTICES {
                    return Err((Some(k + 1), format!("more than {MAX_VERTICES} vertices")));
                }
                positions.extend(xyz);
            }
            Some("f") => {
                let corners: Vec<i64> = words
                    .map(|w| w.split('/').next().unwrap_or_default().parse::<i64>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| (Some(k + 1), format!("a face corner is not a vertex index: {e}")))?;
                if corners.len() < 3 {
                    return Err((Some(k + 1), "a face needs at least three corners".into()));
                }
                faces.push((k + 1, corners));
            }
            _ => {}
        }
    }
    let n = positions.len() / 3;
    if n == 0 {
        return Err((None, "no vertices".into()));
    }
    let mut triangles = Vec::with_capacity(faces.len());
    for (line, corners) in faces {
        let index = |c: i64| -> Result<u32, (Option<usize>, String)> {
            let i = if c > 0 { c - 1 } else { n as i64 + c };
            if c == 0 || i < 0 || i >= n as i64 {
                return Err((Some(line), format!("vertex index {c} is outside 1..={n}")));
            }
            Ok(i as u32)
        };
        let first = index(corners[0])?;
        for pair in corners[1..].windows(2) {
            triangles.push([first, index(pair[0])?, index(pair[1])?]);
        }
    }
    Ok(Mesh { positions, triangles })
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    fn zip_of(entries: &[(&str, &str)]) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("shapes.zip");
        let mut w = zip::ZipWriter::new(std::fs::File::create(&path).unwrap());
        for (name, text) in entries {
            w.start_file(*name, zip::write::SimpleFileOptions::default()).unwrap();
            w.write_all(text.as_bytes()).unwrap();
        }
        w.finish().unwrap();
        (dir, path)
    }

    const NEUTRAL: &str = "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n";

    #[test]
    fn the_face_is_the_neutral_plus_weighted_deltas() {
        let (_d, path) = zip_of(&[
            ("shapes/Neutral.obj", NEUTRAL),
            ("shapes/jawOpen.obj", "v 0 -1 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\n"),
            ("shapes/browUp.obj", "v 0 0 0\nv 1 0 0\nv 1 1 2\nv 0 1 2\nf 1 2 3\n"),
            ("shapes/", ""),
        ]);
        let b = Blendshapes::read_zip(&path).unwrap();
        assert_eq!(b.names, vec!["browUp", "jawOpen"], "name order");
        assert_eq!(b.triangles, vec![[0, 1, 2], [0, 2, 3]], "the quad as a fan");
        let mut out = vec![0.0; 12];
        b.evaluate(&[0.5, 2.0], &mut out);
        assert_eq!(out, vec![0.0, -2.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0]);
    }

    #[test]
    fn bad_zips_are_named() {
        let err = |entries: &[(&str, &str)]| {
            let (_d, path) = zip_of(entries);
            Blendshapes::read_zip(&path).unwrap_err().to_string()
        };
        let e = err(&[("a.obj", NEUTRAL)]);
        assert!(e.contains("no Neutral.obj"), "{e}");
        let e = err(&[("Neutral.obj", NEUTRAL), ("smile.obj", "v 0 0 0\nf 1 1 1\n")]);
        assert!(e.contains("smile.obj") && e.contains("1 vertices where the neutral mesh has 4"), "{e}");
        let e = err(&[("Neutral.obj", NEUTRAL), ("smile.obj", "v 0 0\n")]);
        assert!(e.contains("smile.obj, line 1") && e.contains("three"), "{e}");
        let e = err(&[("Neutral.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), ("s.obj", NEUTRAL)]);
        assert!(e.contains("Neutral.obj, line 4") && e.contains("vertex index 9"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("x.zip"), "not a zip").unwrap();
        let e = Blendshapes::read_zip(&dir.path().join("x.zip")).unwrap_err().to_string();
        assert!(e.contains("x.zip") && e.contains("not a readable zip"), "{e}");
    }

    /// Found by reading the format's limits: a shape at +1e308 over a neutral at −1e308 has
    /// an infinite delta, which would make every pose infinite.
    #[test]
    fn a_delta_beyond_f64_is_refused() {
        let (_d, path) = zip_of(&[
            ("Neutral.obj", "v -1e308 0 0\nv 1 0 0\nv 0 1 0\n"),
            ("far.obj", "v 1e308 0 0\nv 1 0 0\nv 0 1 0\n"),
        ]);
        let e = Blendshapes::read_zip(&path).unwrap_err().to_string();
        assert!(e.contains("far.obj") && e.contains("vertex 1"), "{e}");
    }

    #[test]
    fn negative_indices_count_from_the_end() {
        let mesh = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2]]);
    }

    /// The ARKit reference shapes of the shared data: 51 shapes on 1,220 vertices.
    #[test]
    fn the_arkit_reference_shapes_read() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/datasets/arkit_blendshapes/ARKit_reference_blendshapes.zip");
        if !path.exists() {
            assert!(std::env::var_os("CI").is_none(), "CI must have ../shared/datasets");
            eprintln!("SKIPPED the_arkit_reference_shapes_read: {} not found", path.display());
            return;
        }
        let b = Blendshapes::read_zip(&path).unwrap();
        assert_eq!((b.names.len(), b.vertex_count(), b.triangles.len()), (51, 1220, 2304));
        assert!(b.names.iter().any(|n| n == "jawOpen") && !b.names.iter().any(|n| n == "tongueOut"));
        // jawOpen moves some vertex by more than a millimetre-scale amount; browInnerUp too.
        let moves = |name: &str| {
            let i = b.names.iter().position(|n| n == name).unwrap();
            b.deltas[i * 3660..(i + 1) * 3660].iter().fold(0.0f64, |m, d| m.max(d.abs()))
        };
        assert!(moves("jawOpen") > 0.0 && moves("browInnerUp") > 0.0);
    }
}
