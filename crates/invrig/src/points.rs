//! Which points of a mesh the mapping reads, and their positions.

use crate::error::{InvrigError, Result};

/// `count` vertices of the mesh `rest` (`x, y, z` per vertex) spread over it by farthest-point
/// sampling from vertex 0 (each next vertex is the one farthest from all taken, the lower
/// index on ties), returned in increasing order; every vertex when `count` is 0 or at least
/// the vertex count. Deterministic in the mesh.
pub fn spread(rest: &[f64], count: usize) -> Vec<usize> {
    let n = rest.len() / 3;
    if count == 0 || count >= n {
        return (0..n).collect();
    }
    let p = |i: usize| &rest[3 * i..3 * i + 3];
    let d2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(u, v)| (u - v) * (u - v)).sum::<f64>();
    let mut nearest: Vec<f64> = (0..n).map(|i| d2(p(i), p(0))).collect();
    let mut taken = vec![0];
    while taken.len() < count {
        let far = (0..n).max_by(|&a, &b| nearest[a].total_cmp(&nearest[b]).then(b.cmp(&a))).unwrap_or(0);
        taken.push(far);
        for (i, m) in nearest.iter_mut().enumerate() {
            *m = m.min(d2(p(i), p(far)));
        }
    }
    taken.sort_unstable();
    taken
}

/// The positions of `points` (vertex indices) of every pose in `meshes` (`3V` values a
/// pose): `3 · points.len()` values a pose.
pub fn select(meshes: &[f64], vertices: usize, points: &[usize]) -> Vec<f64> {
    meshes
        .chunks_exact(3 * vertices)
        .flat_map(|mesh| points.iter().flat_map(move |&v| mesh[3 * v..3 * v + 3].iter().copied()))
        .collect()
}

/// The vertex indices `points` (as a table stores them), each checked against the rig's
/// `vertices`.
///
/// # Errors
/// [`InvrigError::Param`] naming the first point that is no vertex of the rig.
pub fn check(points: &[i64], vertices: usize) -> Result<Vec<usize>> {
    points
        .iter()
        .map(|&p| match usize::try_from(p) {
            Ok(v) if v < vertices => Ok(v),
            _ => Err(InvrigError::Param {
                name: "point",
                value: p as f64,
                why: "is no vertex of the rig (points are vertex indices of the rig's evaluated mesh)",
            }),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn farthest_points_take_the_extremes_first() {
        // Five vertices on a line at 0, 1, 2, 3, 10.
        let rest: Vec<f64> = [0.0, 1.0, 2.0, 3.0, 10.0].iter().flat_map(|&x| [x, 0.0, 0.0]).collect();
        assert_eq!(spread(&rest, 2), vec![0, 4]);
        // Then the vertex farthest from both 0 and 10: 3 (distance 3 from 0, 7 from 10).
        assert_eq!(spread(&rest, 3), vec![0, 3, 4]);
        assert_eq!(spread(&rest, 0), vec![0, 1, 2, 3, 4]);
        assert_eq!(spread(&rest, 9), vec![0, 1, 2, 3, 4]);
        assert_eq!(check(&[4, 0], 5).unwrap(), vec![4, 0]);
        assert!(check(&[5], 5).is_err() && check(&[-1], 5).is_err());
    }

    #[test]
    fn selects_points_of_every_pose() {
        let meshes: Vec<f64> = (0..18).map(f64::from).collect(); // two poses of three vertices
        assert_eq!(select(&meshes, 3, &[2, 0]), vec![6.0, 7.0, 8.0, 0.0, 1.0, 2.0, 15.0, 16.0, 17.0, 9.0, 10.0, 11.0]);
    }
}
