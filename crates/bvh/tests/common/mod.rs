//! Shared test helpers: locating the real data, and a small independent 4×4 matrix FK.
#![allow(dead_code)]

use std::path::PathBuf;

use reprise_bvh::{Bvh, Channel};

/// The CMU BVH folder `../shared/datasets/cmu_bvh` beside the repository, or `None` (after
/// printing a visible SKIPPED line) when `../shared/datasets` is absent. Panics instead when
/// the environment variable `CI` is set (CI must have the data), or when the datasets are
/// there but the CMU folder is not.
pub fn cmu_dir(test: &str) -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets");
    if !root.is_dir() {
        if std::env::var_os("CI").is_some() {
            panic!("{test}: ../shared/datasets not found at {} and CI is set", root.display());
        }
        eprintln!("SKIPPED {test}: ../shared/datasets not found");
        return None;
    }
    let dir = root.join("cmu_bvh");
    assert!(dir.is_dir(), "{test}: {} is missing from the datasets", dir.display());
    Some(dir)
}

pub type M4 = [[f64; 4]; 4];

pub fn mat_mul(a: &M4, b: &M4) -> M4 {
    let mut c = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            c[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

pub fn translation(t: [f64; 3]) -> M4 {
    [[1.0, 0.0, 0.0, t[0]], [0.0, 1.0, 0.0, t[1]], [0.0, 0.0, 1.0, t[2]], [0.0, 0.0, 0.0, 1.0]]
}

/// Right-handed rotation about a coordinate axis (0 = X, 1 = Y, 2 = Z), column vectors.
pub fn axis_rotation(axis: usize, degrees: f64) -> M4 {
    let (s, c) = degrees.to_radians().sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0, 0.0], [0.0, c, -s, 0.0], [0.0, s, c, 0.0], [0.0, 0.0, 0.0, 1.0]],
        1 => [[c, 0.0, s, 0.0], [0.0, 1.0, 0.0, 0.0], [-s, 0.0, c, 0.0], [0.0, 0.0, 0.0, 1.0]],
        _ => [[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
    }
}

/// Forward kinematics straight from one frame's raw channel values: per node,
/// `world = parent_world · T(offset, with position channels replacing its axes) · R_1 · R_2 · …`
/// with the rotation channels in declared order. Returns xyz interleaved per node.
pub fn fk_from_channels(bvh: &Bvh, frame: &[f64]) -> Vec<f64> {
    let mut worlds: Vec<M4> = Vec::with_capacity(bvh.nodes.len());
    let mut out = Vec::with_capacity(3 * bvh.nodes.len());
    for node in &bvh.nodes {
        let mut t = node.offset;
        for (i, channel) in node.channels.iter().enumerate() {
            match channel {
                Channel::Xposition => t[0] = frame[node.first_column + i],
                Channel::Yposition => t[1] = frame[node.first_column + i],
                Channel::Zposition => t[2] = frame[node.first_column + i],
                _ => {}
            }
        }
        let mut local = translation(t);
        for (i, channel) in node.channels.iter().enumerate() {
            let axis = match channel {
                Channel::Xrotation => 0,
                Channel::Yrotation => 1,
                Channel::Zrotation => 2,
                _ => continue,
            };
            local = mat_mul(&local, &axis_rotation(axis, frame[node.first_column + i]));
        }
        let world = match node.parent {
            Some(p) => mat_mul(&worlds[p], &local),
            None => local,
        };
        out.extend([world[0][3], world[1][3], world[2][3]]);
        worlds.push(world);
    }
    out
}

/// Largest absolute difference between two equally long slices.
pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}
