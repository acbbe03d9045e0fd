//! The Motion Graphs baseline of Kovar, Gleicher & Pighin (2002), adapted to rig space as
//! the paper's comparison did (`../shared/method.md` §5.6).
//!
//! - **Motions** are the labeled segments; a frame's pose is its scaled control vector $z$.
//! - **Windowed distance** ([`window_distances`]): for frames $A_i$ and $B_j$,
//!   $D(i,j) = \sum_{p=0}^{k-1}\lVert z^A_{i+p} - z^B_{j-k+1+p}\rVert^2$ — the window on $A$
//!   starts at $A_i$, the one on $B$ ends at $B_j$, so it measures exactly the frames a
//!   transition blends. Frame distances come from one matrix product
//!   ($\lVert a-b\rVert^2 = \lVert a\rVert^2 + \lVert b\rVert^2 - 2a^\top b$), windows from sums along
//!   diagonals: $O(N_AN_BP)$ in all.
//! - **Candidates** ([`local_minima`]): $D$ strictly smaller than every other value in its
//!   $(2\rho+1)^2$ neighbourhood; trivial self-transitions (same motion, $|j - (i+k-1)| < k$)
//!   excluded.
//! - **Transition** $A_i \to B_{j+1}$: the $k$ frames $\alpha(p)z^A_{i+p} + (1-\alpha(p))z^B_{j-k+1+p}$,
//!   $\alpha(p) = 2(\frac{p+1}k)^3 - 3(\frac{p+1}k)^2 + 1$ ([`blend_weight`]), then playback
//!   continues at $B_{j+1}$.
//! - **Graph** ([`Graph`]): one node per frame; an edge to the next frame of its motion
//!   (cost 1 frame) and one per transition (cost $k$ frames, leaving at $A_i$ and arriving at
//!   $B_{j+1}$); pruned to the largest strongly connected component ([`largest_scc`],
//!   Tarjan); searched by Dijkstra for the fewest frames to any frame of a target set
//!   ([`Graph::shortest_to`]).
#![warn(missing_docs)]

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// $\alpha(p)$ for a blend of $k$ frames: 1 at $p = -1$, 0 at $p = k - 1$ (the last blended
/// frame is all $B$), zero slope at both, $\alpha(p) + \alpha(k-2-p) = 1$. method.md §5.7
/// writes the end as $\alpha(k) = 0$; with its own formula that holds at $p = k - 1$.
pub fn blend_weight(p: f64, k: usize) -> f64 {
    let s = (p + 1.0) / k as f64;
    2.0 * s * s * s - 3.0 * s * s + 1.0
}

/// One frame a Motion Graphs path plays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathFrame {
    /// A node's own frame.
    Node(usize),
    /// A transition's blended frame $\alpha\,z_a + (1-\alpha)\,z_b$, blending into node
    /// `into` (the transition's destination).
    Blend {
        /// The frame being left ($A_{i+p}$).
        a: usize,
        /// The frame blended into ($B_{j-k+1+p}$).
        b: usize,
        /// $\alpha(p)$, the weight on `a`.
        weight: f64,
        /// The transition's destination node.
        into: usize,
    },
}

impl PathFrame {
    /// The node whose label the frame shows (a blend shows its destination's).
    pub fn node(&self) -> usize {
        match *self {
            PathFrame::Node(v) => v,
            PathFrame::Blend { into, .. } => into,
        }
    }
}

/// Appends to `queue` (frames planned but not yet shown) the frames path `path` plays:
/// each edge's destination frame, a transition edge $A_i \to B_{j+1}$ (`ends(e)` =
/// (from, to, is a transition)) first playing the $k$ blended frames
/// $\alpha(p)\,z^A_{i+p} + (1-\alpha(p))\,z^B_{j-k+1+p}$ that replace $A_i \dots A_{i+k-1}$
/// (method.md §5.3). $A_i$ gives way to the first of them when it is still queued; when it
/// was shown already (the queue is empty), the blend starts at $p = 1$: its $p = 0$ twin,
/// still almost all $A_i$, would only stall the motion.
pub fn play_path(queue: &mut Vec<PathFrame>, path: &[usize], ends: impl Fn(usize) -> (usize, usize, bool), k: usize) {
    for &e in path {
        let (from, dest, transition) = ends(e);
        if transition {
            let first = if queue.pop().is_some() { 0 } else { 1 };
            for p in first..k {
                let weight = blend_weight(p as f64, k);
                queue.push(PathFrame::Blend { a: from + p, b: dest - k + p, weight, into: dest });
            }
        }
        queue.push(PathFrame::Node(dest));
    }
}

/// $D(i,j)$ for motions `a` (`na × dim`, row-major) and `b` (`nb × dim`) with window
/// `k`, row-major `na × nb`; entries whose windows leave either motion ($i + k > n_a$ or
/// $j + 1 < k$) are `+∞`. With `dim = 0` (no controls) the motions have no frames and the result is
/// empty. The result
/// has `na × nb` entries: callers bound the motions' lengths (the motion-graph stage's
/// `--max-pair-frames`).
pub fn window_distances(a: &[f64], b: &[f64], dim: usize, k: usize) -> Vec<f64> {
    let (na, nb) = (a.len().checked_div(dim).unwrap_or(0), b.len().checked_div(dim).unwrap_or(0));
    let am = faer::Mat::<f64>::from_fn(na, dim, |i, c| a[i * dim + c]);
    let bm = faer::Mat::<f64>::from_fn(nb, dim, |i, c| b[i * dim + c]);
    let mut g = faer::Mat::<f64>::zeros(na, nb);
    faer::linalg::matmul::matmul(g.as_mut(), faer::Accum::Replace, am.as_ref(), bm.transpose(), 1.0, faer::Par::Seq);
    let sq = |m: &[f64], i: usize| m[i * dim..(i + 1) * dim].iter().map(|v| v * v).sum::<f64>();
    let (an, bn): (Vec<f64>, Vec<f64>) = ((0..na).map(|i| sq(a, i)).collect(), (0..nb).map(|j| sq(b, j)).collect());
    let d = |i: usize, j: usize| (an[i] + bn[j] - 2.0 * g[(i, j)]).max(0.0);
    let mut out = vec![f64::INFINITY; na * nb];
    if k == 0 || k > na || k > nb {
        return out;
    }
    // Along each diagonal (i + p, j − k + 1 + p): a sliding sum of k frame distances.
    for i in 0..=na - k {
        for j in k - 1..nb {
            // D(i, j) = D(i − 1, j − 1) − d(i − 1, j − k) + d(i + k − 1, j): reuse when possible.
            let v = if i > 0 && j >= k && out[(i - 1) * nb + (j - 1)].is_finite() {
                out[(i - 1) * nb + (j - 1)] - d(i - 1, j - k) + d(i + k - 1, j)
            } else {
                (0..k).map(|p| d(i + p, j + 1 + p - k)).sum()
            };
            out[i * nb + j] = v.max(0.0);
        }
    }
    out
}

/// The strict local minima of a row-major `rows × cols` surface within radius `rho` (finite
/// values only), as `(i, j, value)`; `exclude(i, j)` removes candidates. A surface with
/// fewer than `rows × cols` values has none.
pub fn local_minima(
    d: &[f64],
    rows: usize,
    cols: usize,
    rho: usize,
    exclude: impl Fn(usize, usize) -> bool,
) -> Vec<(usize, usize, f64)> {
    let mut out = Vec::new();
    if rows.checked_mul(cols).is_none_or(|len| d.len() < len) {
        return out;
    }
    for i in 0..rows {
        for j in 0..cols {
            let v = d[i * cols + j];
            if !v.is_finite() || exclude(i, j) {
                continue;
            }
            let is_min = (i.saturating_sub(rho)..i.saturating_add(rho).saturating_add(1).min(rows)).all(|a| {
                (j.saturating_sub(rho)..j.saturating_add(rho).saturating_add(1).min(cols))
                    .all(|b| (a == i && b == j) || d[a * cols + b] > v)
            });
            if is_min {
                out.push((i, j, v));
            }
        }
    }
    out
}

/// An edge that cannot be in a [`Graph`]: an end that is not a node, or a cost that is
/// not a positive number of frames.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("edge {id} from node {from} to node {to} costing {cost} does not fit a graph of {nodes} nodes with costs 1..=2^32-1")]
pub struct BadEdge {
    /// The edge's id.
    pub id: usize,
    /// Its start, as given.
    pub from: i64,
    /// Its end, as given.
    pub to: i64,
    /// Its cost, as given.
    pub cost: i64,
    /// The graph's node count.
    pub nodes: usize,
}

/// A directed graph with integer edge costs over nodes `0..n`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Graph {
    /// Adjacency: per node, (target, cost, edge id).
    pub adj: Vec<Vec<(usize, u32, usize)>>,
}

impl Graph {
    /// `n` nodes, no edges.
    pub fn new(n: usize) -> Self {
        Self { adj: vec![Vec::new(); n] }
    }

    /// Adds edge `id` from `a` to `b` costing `cost`.
    ///
    /// # Panics
    /// If `a` is not a node. Edges read from a file go through [`Graph::try_add`] or
    /// [`Graph::from_edges`] instead, which refuse them.
    pub fn add(&mut self, a: usize, b: usize, cost: u32, id: usize) {
        self.adj[a].push((b, cost, id));
    }

    /// Adds edge `id` from `a` to `b` costing `cost` frames, or refuses it if an end is
    /// not a node or the cost is not in `1..=u32::MAX`.
    pub fn try_add(&mut self, a: i64, b: i64, cost: i64, id: usize) -> Result<(), BadEdge> {
        let n = self.adj.len();
        let node = |v: i64| usize::try_from(v).ok().filter(|&v| v < n);
        match (node(a), node(b), u32::try_from(cost).ok().filter(|&c| c > 0)) {
            (Some(a), Some(b), Some(cost)) => {
                self.adj[a].push((b, cost, id));
                Ok(())
            }
            _ => Err(BadEdge { id, from: a, to: b, cost, nodes: n }),
        }
    }

    /// A graph of `n` nodes with `(from, to, cost)` edges numbered in order, as read
    /// from a file: every edge is checked ([`Graph::try_add`]).
    pub fn from_edges(n: usize, edges: impl IntoIterator<Item = (i64, i64, i64)>) -> Result<Self, BadEdge> {
        let mut g = Self::new(n);
        for (id, (a, b, c)) in edges.into_iter().enumerate() {
            g.try_add(a, b, c, id)?;
        }
        Ok(g)
    }

    /// The cheapest path from `start` to any node with `target(node)`, within the nodes
    /// `alive`: (total cost, the edge ids in order), or `None` if unreachable. A node
    /// missing from `alive` (shorter than the graph) counts as pruned; costs add up
    /// saturating (a path of `u32::MAX` frames or more counts as unreachable), so no input
    /// makes the search panic.
    pub fn shortest_to(
        &self,
        start: usize,
        alive: &[bool],
        target: impl Fn(usize) -> bool,
    ) -> Option<(u32, Vec<usize>)> {
        self.cheapest_to(start, alive, target, |cost, _| u64::from(cost))
    }

    /// A near-shortest path, chosen under `seed`: Dijkstra on the costs perturbed to
    /// $c'_e = c_e\,(1 + s\,u_e)$ with $u_e \in [0, 1)$ a hash of (seed, edge id), so the
    /// path found costs at most $(1 + s)$ times the shortest (true cost $\le c' $ of it $\le$
    /// $c'$ of the shortest $\le (1 + s)\,$ its cost). `slack` $s = 0$ is [`Self::shortest_to`].
    /// Returns the path's true cost and edges.
    pub fn near_shortest_to(
        &self,
        start: usize,
        alive: &[bool],
        target: impl Fn(usize) -> bool,
        slack: f64,
        seed: u64,
    ) -> Option<(u32, Vec<usize>)> {
        // Fixed point: costs in 1/1024 frames, so small perturbations survive rounding.
        let scale = 1024.0;
        self.cheapest_to(start, alive, target, |cost, e| {
            let u = (splitmix(seed ^ splitmix(e as u64)) >> 11) as f64 / (1u64 << 53) as f64;
            (f64::from(cost) * (1.0 + slack.max(0.0) * u) * scale).round() as u64
        })
    }

    /// Dijkstra under `weight(cost, edge id)`; returns the true cost (sum of `cost`) and
    /// the edges of the path that is cheapest under `weight`.
    fn cheapest_to(
        &self,
        start: usize,
        alive: &[bool],
        target: impl Fn(usize) -> bool,
        weight: impl Fn(u32, usize) -> u64,
    ) -> Option<(u32, Vec<usize>)> {
        #[derive(PartialEq, Eq)]
        struct Item(u64, usize);
        impl Ord for Item {
            fn cmp(&self, o: &Self) -> Ordering {
                o.0.cmp(&self.0).then(o.1.cmp(&self.1))
            }
        }
        impl PartialOrd for Item {
            fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
                Some(self.cmp(o))
            }
        }
        let n = self.adj.len();
        let alive_at = |v: usize| alive.get(v).copied().unwrap_or(false);
        if start >= n || !alive_at(start) {
            return None;
        }
        let mut best = vec![u64::MAX; n];
        let mut via: Vec<Option<(usize, usize, u32)>> = vec![None; n];
        let mut heap = BinaryHeap::from([Item(0, start)]);
        best[start] = 0;
        while let Some(Item(c, v)) = heap.pop() {
            if c > best[v] {
                continue;
            }
            if v != start && target(v) {
                let (mut edges, mut total) = (Vec::new(), 0u64);
                let mut at = v;
                while let Some((prev, e, cost)) = via[at] {
                    edges.push(e);
                    total += u64::from(cost);
                    at = prev;
                }
                edges.reverse();
                // A path of u32::MAX frames or more counts as unreachable.
                return u32::try_from(total).ok().filter(|&t| t < u32::MAX).map(|t| (t, edges));
            }
            for &(w, cost, e) in &self.adj[v] {
                let next = c.saturating_add(weight(cost, e));
                if w < n && alive_at(w) && next < best[w] {
                    best[w] = next;
                    via[w] = Some((v, e, cost));
                    heap.push(Item(next, w));
                }
            }
        }
        None
    }
}

/// SplitMix64's finaliser: a well-mixed 64-bit hash of `x`.
fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// Membership of the largest strongly connected component (Tarjan's algorithm,
/// iterative); ties go to the component found first. Edges to nodes outside the graph
/// (possible only through the public `adj`) are ignored.
pub fn largest_scc(g: &Graph) -> Vec<bool> {
    let n = g.adj.len();
    let (mut index, mut low, mut on) = (vec![usize::MAX; n], vec![0usize; n], vec![false; n]);
    let (mut stack, mut comp) = (Vec::new(), vec![usize::MAX; n]);
    let (mut next, mut ncomp) = (0, 0);
    let mut sizes = Vec::new();
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut call: Vec<(usize, usize)> = vec![(root, 0)];
        index[root] = next;
        low[root] = next;
        next += 1;
        stack.push(root);
        on[root] = true;
        while let Some(&mut (v, ref mut ei)) = call.last_mut() {
            if let Some(&(w, _, _)) = g.adj[v].get(*ei) {
                *ei += 1;
                if w >= n {
                    continue;
                }
                if index[w] == usize::MAX {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on[w] = true;
                    call.push((w, 0));
                } else if on[w] {
                    low[v] = low[v].min(index[w]);
                }
            } else {
                call.pop();
                if let Some(&(u, _)) = call.last() {
                    low[u] = low[u].min(low[v]);
                }
                if low[v] == index[v] {
                    let mut size = 0;
                    while let Some(w) = stack.pop() {
                        on[w] = false;
                        comp[w] = ncomp;
                        size += 1;
                        if w == v {
                            break;
                        }
                    }
                    sizes.push(size);
                    ncomp += 1;
                }
            }
        }
    }
    let best = (0..ncomp).max_by_key(|&c| (sizes[c], std::cmp::Reverse(c))).unwrap_or(0);
    comp.iter().map(|&c| c == best && ncomp > 0).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// method.md §5.7 (c): α(−1) = 1, α(k − 1) = 0 (the oracle's "α(k)" is off by one for
    /// its own formula), zero slopes there, point symmetry.
    #[test]
    fn blend_weights_have_the_properties() {
        let k = 12;
        assert!((blend_weight(-1.0, k) - 1.0).abs() < 1e-15 && blend_weight((k - 1) as f64, k).abs() < 1e-15);
        let h = 1e-6;
        for p in [-1.0, (k - 1) as f64] {
            let slope = (blend_weight(p + h, k) - blend_weight(p - h, k)) / (2.0 * h);
            assert!(slope.abs() < 1e-9, "{slope}");
        }
        for p in 0..k {
            let s = blend_weight(p as f64, k) + blend_weight(k as f64 - 2.0 - p as f64, k);
            assert!((s - 1.0).abs() < 1e-12);
        }
    }

    /// The sliding recurrence equals brute force; a motion against itself is 0 where the
    /// windows coincide (j = i + k − 1).
    #[test]
    fn window_distances_match_brute_force() {
        let dim = 3;
        let a: Vec<f64> = (0..20 * dim).map(|i| ((i * 37) % 11) as f64 * 0.3).collect();
        let b: Vec<f64> = (0..15 * dim).map(|i| ((i * 53) % 7) as f64 * 0.5).collect();
        let k = 4;
        let d = window_distances(&a, &b, dim, k);
        let fd = |x: &[f64], i: usize, y: &[f64], j: usize| -> f64 {
            (0..dim).map(|c| (x[i * dim + c] - y[j * dim + c]).powi(2)).sum()
        };
        for i in 0..=20 - k {
            for j in k - 1..15 {
                let want: f64 = (0..k).map(|p| fd(&a, i + p, &b, j + 1 + p - k)).sum();
                assert!((d[i * 15 + j] - want).abs() < 1e-9 * want.max(1.0), "({i},{j})");
            }
        }
        assert!(d[19 * 15].is_infinite() && d[0].is_infinite());
        let s = window_distances(&a, &a, dim, k);
        for i in 0..=20 - k {
            assert!(s[i * 20 + i + k - 1] < 1e-9);
        }
    }

    /// Near-shortest paths: on a ladder of two-way choices (costs 10 or 11 per rung), slack
    /// 0 is the shortest path; slack 0.2 finds different paths under different seeds, each
    /// within 1.2 × the shortest; the same seed finds the same path.
    #[test]
    fn near_shortest_paths_vary_within_the_slack() {
        let rungs = 8;
        let mut g = Graph::new(rungs + 1);
        let mut id = 0;
        for r in 0..rungs {
            for cost in [10, 11] {
                g.add(r, r + 1, cost, id);
                id += 1;
            }
        }
        let alive = vec![true; rungs + 1];
        let goal = |v: usize| v == rungs;
        let (best, _) = g.shortest_to(0, &alive, goal).unwrap();
        assert_eq!(best, 80);
        assert_eq!(g.near_shortest_to(0, &alive, goal, 0.0, 5).unwrap().0, 80);
        let paths: std::collections::BTreeSet<Vec<usize>> = (0..20)
            .map(|seed| {
                let (cost, path) = g.near_shortest_to(0, &alive, goal, 0.2, seed).unwrap();
                assert!(f64::from(cost) <= 1.2 * f64::from(best), "{cost}");
                assert_eq!(g.near_shortest_to(0, &alive, goal, 0.2, seed).unwrap().1, path);
                path
            })
            .collect();
        assert!(paths.len() > 5, "only {} distinct paths", paths.len());
    }

    /// Local minima: the two dips of a surface, not its slopes; exclusions respected.
    #[test]
    fn local_minima_find_the_dips() {
        let (r, c) = (6, 7);
        let d: Vec<f64> = (0..r * c)
            .map(|x| {
                let (i, j) = ((x / c) as f64, (x % c) as f64);
                ((i - 1.0).powi(2) + (j - 1.0).powi(2)).min((i - 4.0).powi(2) + (j - 5.0).powi(2) + 0.5)
            })
            .collect();
        let m = local_minima(&d, r, c, 1, |_, _| false);
        assert_eq!(m.iter().map(|&(i, j, _)| (i, j)).collect::<Vec<_>>(), vec![(1, 1), (4, 5)]);
        let m = local_minima(&d, r, c, 1, |i, _| i == 1);
        assert_eq!(m.len(), 1);
    }

    /// method.md §5.7 (e): a cycle with a dangling tail keeps the cycle; search finds the
    /// cheapest path and respects pruning.
    #[test]
    fn scc_keeps_the_cycle_and_search_is_shortest() {
        let mut g = Graph::new(6);
        // Cycle 0 → 1 → 2 → 3 → 0, tail 3 → 4 → 5.
        for (e, (a, b, c)) in
            [(0, 1, 1), (1, 2, 1), (2, 3, 1), (3, 0, 1), (3, 4, 1), (4, 5, 1), (0, 2, 5)].iter().enumerate()
        {
            g.add(*a, *b, *c, e);
        }
        let alive = largest_scc(&g);
        assert_eq!(alive, vec![true, true, true, true, false, false]);
        let (cost, path) = g.shortest_to(0, &alive, |v| v == 2).unwrap();
        assert_eq!((cost, path), (2, vec![0, 1]));
        assert!(g.shortest_to(0, &alive, |v| v == 5).is_none());
        assert!(g.shortest_to(0, &[true; 6], |v| v == 5).is_some());
    }

    /// Catalogue: edges read from a file that name no node, or cost nothing, are refused
    /// by `from_edges` (was: `adj[a]` index panic); search and pruning never panic, even
    /// on an `alive` of the wrong length or a path whose cost overflows.
    #[test]
    fn bad_edges_are_refused_and_search_is_total() {
        let e = Graph::from_edges(3, [(0, 1, 1), (1, 5000, 12)]).unwrap_err();
        assert_eq!((e.id, e.to, e.nodes), (1, 5000, 3));
        assert!(e.to_string().contains("edge 1 from node 1 to node 5000"));
        assert!(Graph::from_edges(3, [(-1, 1, 1)]).is_err());
        assert!(Graph::from_edges(3, [(0, 1, 0)]).is_err());
        assert!(Graph::from_edges(3, [(0, 1, 1 << 40)]).is_err());
        let mut g =
            Graph::from_edges(3, [(0, 1, i64::from(u32::MAX)), (1, 2, i64::from(u32::MAX)), (2, 0, 1)]).unwrap();
        assert_eq!(g.shortest_to(0, &[true, true, true], |v| v == 2), None);
        assert_eq!(g.shortest_to(2, &[true, true, true], |v| v == 0).map(|p| p.0), Some(1));
        assert_eq!(g.shortest_to(0, &[true], |v| v == 2), None);
        g.adj[2].push((99, 1, 3));
        assert_eq!(largest_scc(&g), vec![true, true, true]);
        assert!(local_minima(&[1.0, 2.0], 2, 2, usize::MAX, |_, _| false).is_empty());
        assert!(window_distances(&[1.0; 6], &[1.0; 6], 0, 2).is_empty());
    }
}
