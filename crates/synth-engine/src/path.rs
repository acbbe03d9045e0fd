//! Paths through a latent space for the MOVE command (§5.3): a straight line, or the
//! shortest path through the training points, resampled to constant speed.
//!
//! The graph (method.md §0 on the paper's ambiguity): by default the paper's **complete**
//! graph over the training points ($k = 0$; Dijkstra over the implicit $O(N^2)$ edges in
//! $O(N)$ memory, $O(N^2)$ time per MOVE), or the $k$ nearest training points of each
//! point joined (symmetrised); Dijkstra minimises the sum of edge **costs**. With
//! [`EdgeCost::Power`] the cost is $\lVert x_i - x_j\rVert^p$ (the default, $p = 4$:
//! many short hops through the data are cheaper than one long jump); with
//! [`EdgeCost::InversePower`] it is the paper's literal "weight"
//! $\lVert x_i - x_j\rVert^{-p}$ used as a cost, which favours long jumps — kept for
//! comparison.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use reprise_numerics::vector::dist;

/// How an edge of the training-point graph costs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EdgeCost {
    /// $\lVert\Delta\rVert^p$.
    Power(f64),
    /// $\lVert\Delta\rVert^{-p}$ (the paper's weight read as a cost).
    InversePower(f64),
}

/// The index of the training point (row-major `N × q`) nearest `x`.
pub fn nearest(points: &[f64], q: usize, x: &[f64]) -> usize {
    points.chunks_exact(q).map(|p| dist(p, x)).enumerate().min_by(|a, b| a.1.total_cmp(&b.1)).map_or(0, |(i, _)| i)
}

#[derive(PartialEq)]
struct Item(f64, usize);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0)
    }
}

/// The polyline from `from` to `to` through the training points `points` (row-major
/// `N × q`): `from`, the shortest graph path between the training points nearest each end
/// ($k$-nearest-neighbour graph, symmetrised), then `to`. Falls back to the straight line
/// if the graph does not connect them.
pub fn graph_path(points: &[f64], q: usize, from: &[f64], to: &[f64], k: usize, cost: EdgeCost) -> Vec<Vec<f64>> {
    let n = points.len() / q;
    let pt = |i: usize| &points[i * q..(i + 1) * q];
    let (s, t) = (nearest(points, q, from), nearest(points, q, to));
    let edge = |dd: f64| match cost {
        EdgeCost::Power(p) => dd.powf(p),
        EdgeCost::InversePower(p) => dd.max(1e-12).powf(-p),
    };
    let (best, prev) = if k == 0 || k + 1 >= n {
        complete_dijkstra(n, s, t, |i, j| edge(dist(pt(i), pt(j))))
    } else {
        knn_dijkstra(points, q, k, s, t, edge)
    };
    let mut out = vec![from.to_vec()];
    if best[t].is_finite() {
        let mut chain = vec![t];
        while let Some(&last) = chain.last() {
            if last == s {
                break;
            }
            chain.push(prev[last]);
        }
        out.extend(chain.into_iter().rev().map(|i| pt(i).to_vec()));
    }
    out.push(to.to_vec());
    out
}

/// Dijkstra from `s` to `t` on the complete graph with edge cost `w(i, j)`: the array
/// form (no heap), $O(N^2)$ time and $O(N)$ memory. Returns (cost to each settled node,
/// predecessor).
fn complete_dijkstra(n: usize, s: usize, t: usize, w: impl Fn(usize, usize) -> f64) -> (Vec<f64>, Vec<usize>) {
    let mut best = vec![f64::INFINITY; n];
    let mut prev = vec![usize::MAX; n];
    let mut done = vec![false; n];
    best[s] = 0.0;
    while let Some(i) = (0..n).filter(|&i| !done[i] && best[i].is_finite()).min_by(|&a, &b| best[a].total_cmp(&best[b]))
    {
        done[i] = true;
        if i == t {
            break;
        }
        for j in 0..n {
            if !done[j] {
                let c = best[i] + w(i, j);
                if c < best[j] {
                    best[j] = c;
                    prev[j] = i;
                }
            }
        }
    }
    (best, prev)
}

/// Dijkstra from `s` to `t` on the symmetrised `k`-nearest-neighbour graph.
fn knn_dijkstra(
    points: &[f64],
    q: usize,
    k: usize,
    s: usize,
    t: usize,
    edge: impl Fn(f64) -> f64,
) -> (Vec<f64>, Vec<usize>) {
    let n = points.len() / q;
    let pt = |i: usize| &points[i * q..(i + 1) * q];
    let mut adj: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for i in 0..n {
        let mut d: Vec<(f64, usize)> = (0..n).filter(|&j| j != i).map(|j| (dist(pt(i), pt(j)), j)).collect();
        let kk = k.min(d.len());
        if kk > 0 && kk < d.len() {
            d.select_nth_unstable_by(kk - 1, |a, b| a.0.total_cmp(&b.0));
        }
        for &(dd, j) in &d[..kk] {
            let c = edge(dd);
            adj[i].push((j, c));
            adj[j].push((i, c));
        }
    }
    let mut best = vec![f64::INFINITY; n];
    let mut prev = vec![usize::MAX; n];
    let mut heap = BinaryHeap::new();
    best[s] = 0.0;
    heap.push(Item(0.0, s));
    while let Some(Item(c, i)) = heap.pop() {
        if c > best[i] {
            continue;
        }
        if i == t {
            break;
        }
        for &(j, w) in &adj[i] {
            if c + w < best[j] {
                best[j] = c + w;
                prev[j] = i;
                heap.push(Item(c + w, j));
            }
        }
    }
    (best, prev)
}

/// `frames` points at constant speed along the polyline, the last one at its end (the
/// first step leaves its start).
pub fn resample(polyline: &[Vec<f64>], frames: usize) -> Vec<Vec<f64>> {
    let seg: Vec<f64> = polyline.windows(2).map(|w| dist(&w[0], &w[1])).collect();
    let total: f64 = seg.iter().sum();
    (1..=frames)
        .map(|f| {
            let mut s = total * f as f64 / frames as f64;
            for (i, &l) in seg.iter().enumerate() {
                if s <= l || i == seg.len() - 1 {
                    let u = if l > 0.0 { (s / l).min(1.0) } else { 1.0 };
                    return polyline[i].iter().zip(&polyline[i + 1]).map(|(a, b)| a + u * (b - a)).collect();
                }
                s -= l;
            }
            polyline.last().cloned().unwrap_or_default()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Resampling a bent line gives equal steps ending at the end.
    #[test]
    fn resample_is_constant_speed() {
        let line = vec![vec![0.0, 0.0], vec![3.0, 0.0], vec![3.0, 1.0]];
        let r = resample(&line, 8);
        assert_eq!(r.last().unwrap(), &vec![3.0, 1.0]);
        let mut prev = vec![0.0, 0.0];
        for p in &r {
            let d = dist(&prev, p);
            assert!(d <= 0.5 + 1e-12 && d > 0.35, "{d}");
            prev = p.clone();
        }
    }

    /// The polyline's cost under `p`-th powers of its interior steps.
    fn cost(path: &[Vec<f64>], p: f64) -> f64 {
        path[1..path.len() - 1].windows(2).map(|w| dist(&w[0], &w[1]).powf(p)).sum()
    }

    /// The complete graph (k = 0) never costs more than the 8-nearest-neighbour graph (it
    /// has every edge the other has) and, under the fourth-power cost, takes the same path
    /// on most of 40 random pairs of a seeded 3-D cloud of 300 points.
    #[test]
    fn the_complete_graph_is_never_worse_than_the_neighbour_graph() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let pts: Vec<f64> = (0..900).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let mut same = 0;
        for _ in 0..40 {
            let (a, b): (Vec<f64>, Vec<f64>) = (
                (0..3).map(|_| rng.gen_range(-1.0..1.0)).collect(),
                (0..3).map(|_| rng.gen_range(-1.0..1.0)).collect(),
            );
            let full = graph_path(&pts, 3, &a, &b, 0, EdgeCost::Power(4.0));
            let knn = graph_path(&pts, 3, &a, &b, 8, EdgeCost::Power(4.0));
            assert!(cost(&full, 4.0) <= cost(&knn, 4.0) + 1e-12);
            same += usize::from(full == knn);
        }
        assert!(same >= 30, "{same} of 40 paths identical");
    }

    /// On points along an arc, the power cost walks the arc; the inverse cost jumps.
    #[test]
    fn graph_path_follows_the_data() {
        let pts: Vec<f64> =
            (0..=20).flat_map(|i| [(i as f64 * 0.15).cos() * 2.0, (i as f64 * 0.15).sin() * 2.0]).collect();
        let (a, b) = ([2.0, 0.0], [pts[40], pts[41]]);
        let walk = graph_path(&pts, 2, &a, &b, 4, EdgeCost::Power(4.0));
        assert!(walk.len() >= 20, "{}", walk.len());
        let jump = graph_path(&pts, 2, &a, &b, 4, EdgeCost::InversePower(4.0));
        assert!(jump.len() < walk.len());
    }
}
