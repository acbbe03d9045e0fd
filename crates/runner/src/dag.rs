//! The dependency graph between stages: stage B depends on stage A when one of B's inputs
//! is one of A's outputs (normalised paths compared), or when B lists A in `after`. Owns
//! cycle detection and the run order (topological, ties broken by declaration order).

use std::collections::BTreeSet;

use crate::error::{Error, Result};
use crate::pipeline::Pipeline;

/// Why one stage depends on another.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Edge {
    /// The consumer's input `input` is the producer's output `output`.
    Artifact { output: String, input: String, path: String },
    /// The consumer lists the producer in `after`.
    After,
}

/// The stage graph; stages are identified by their index in [`Pipeline::stages`].
#[derive(Debug, Clone)]
pub struct Dag {
    /// `incoming[b]`: `(a, edge)` for every edge `a -> b`, in declaration order of b's
    /// inputs, then `after`.
    incoming: Vec<Vec<(usize, Edge)>>,
    order: Vec<usize>,
}

impl Dag {
    /// Builds the graph and its run order, refusing cycles.
    pub fn build(pipeline: &Pipeline) -> Result<Self> {
        let mut incoming = vec![Vec::new(); pipeline.stages.len()];
        for (b, stage) in pipeline.stages.iter().enumerate() {
            for (input, path) in &stage.inputs {
                if let Some((a, output)) = producer(pipeline, &path.abs) {
                    let edge = Edge::Artifact { output: output.into(), input: input.clone(), path: path.rel.clone() };
                    incoming[b].push((a, edge));
                }
            }
            for after in &stage.after {
                incoming[b].push((pipeline.index_of(after)?, Edge::After));
            }
        }
        let mut dag = Self { incoming, order: Vec::new() };
        dag.order = dag.topological().map_err(|cycle| Error::Cycle {
            file: pipeline.file.clone(),
            cycle: cycle.iter().map(|&i| pipeline.stages[i].name.as_str()).collect::<Vec<_>>().join(" -> "),
        })?;
        Ok(dag)
    }

    /// Stage indices in run order.
    #[must_use]
    pub fn order(&self) -> &[usize] {
        &self.order
    }

    /// The edges into stage `b`.
    #[must_use]
    pub fn incoming(&self, b: usize) -> &[(usize, Edge)] {
        &self.incoming[b]
    }

    /// The distinct stages `b` depends on directly, in declaration order.
    #[must_use]
    pub fn deps(&self, b: usize) -> BTreeSet<usize> {
        self.incoming[b].iter().map(|(a, _)| *a).collect()
    }

    /// The names of `b`'s inputs that some stage produces (the rest are source files).
    #[must_use]
    pub fn produced_inputs(&self, b: usize) -> BTreeSet<&str> {
        self.incoming[b]
            .iter()
            .filter_map(|(_, edge)| match edge {
                Edge::Artifact { input, .. } => Some(input.as_str()),
                Edge::After => None,
            })
            .collect()
    }

    /// Stage `b` and every stage it depends on, directly or not.
    #[must_use]
    pub fn with_ancestors(&self, b: usize) -> BTreeSet<usize> {
        let mut seen = BTreeSet::from([b]);
        let mut todo = vec![b];
        while let Some(next) = todo.pop() {
            for (a, _) in &self.incoming[next] {
                if seen.insert(*a) {
                    todo.push(*a);
                }
            }
        }
        seen
    }

    /// Kahn's algorithm, always taking the earliest-declared ready stage. On a cycle,
    /// returns it as a closed walk `[a, b, …, a]`.
    fn topological(&self) -> Result<Vec<usize>, Vec<usize>> {
        let n = self.incoming.len();
        let deps: Vec<BTreeSet<usize>> = (0..n).map(|b| self.deps(b)).collect();
        let mut waiting: Vec<usize> = deps.iter().map(BTreeSet::len).collect();
        let mut ready: BTreeSet<usize> = (0..n).filter(|&b| waiting[b] == 0).collect();
        let mut order = Vec::with_capacity(n);
        while let Some(a) = ready.pop_first() {
            order.push(a);
            for b in (0..n).filter(|&b| deps[b].contains(&a)) {
                waiting[b] -= 1;
                if waiting[b] == 0 {
                    ready.insert(b);
                }
            }
        }
        if order.len() == n {
            return Ok(order);
        }
        // Every stage left has a dependency that is also left: walk dependencies backwards
        // from the earliest-declared one until a stage repeats.
        let start = (0..n).find(|b| waiting[*b] > 0).unwrap_or(0);
        let mut walk = vec![start];
        loop {
            let last = walk[walk.len() - 1];
            let prev = deps[last].iter().copied().find(|a| waiting[*a] > 0).unwrap_or(last);
            if let Some(pos) = walk.iter().position(|&s| s == prev) {
                let mut cycle: Vec<usize> = walk[pos..].iter().rev().copied().collect();
                // Start the cycle at its earliest-declared stage, then close it.
                let first = cycle.iter().enumerate().min_by_key(|(_, s)| **s).map_or(0, |(i, _)| i);
                cycle.rotate_left(first);
                cycle.push(cycle[0]);
                return Err(cycle);
            }
            walk.push(prev);
        }
    }
}

fn producer<'a>(pipeline: &'a Pipeline, path: &std::path::Path) -> Option<(usize, &'a str)> {
    pipeline.stages.iter().enumerate().find_map(|(a, stage)| {
        stage.outputs.iter().find(|(_, out)| out.abs == path).map(|(name, _)| (a, name.as_str()))
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    fn dag(stages: &str) -> Result<(Pipeline, Dag)> {
        let text = format!("[pipeline]\nname = \"t\"\n{stages}");
        let pipeline = Pipeline::parse(&text, "pipeline.toml", Path::new("/p"))?;
        let dag = Dag::build(&pipeline)?;
        Ok((pipeline, dag))
    }

    fn order(stages: &str) -> Vec<String> {
        let (p, d) = dag(stages).unwrap();
        d.order().iter().map(|&i| p.stages[i].name.clone()).collect()
    }

    #[test]
    fn topological_order_follows_artifacts() {
        let stages = r#"
            [stage.report]
            bin = "r"
            inputs.m = "m.parquet"
            [stage.fit]
            bin = "f"
            inputs.x = "./x.parquet"
            outputs.m = "m.parquet"
            [stage.ingest]
            bin = "i"
            outputs.x = "x.parquet"
        "#;
        assert_eq!(order(stages), ["ingest", "fit", "report"]);
    }

    #[test]
    fn ties_are_broken_by_declaration_order() {
        let stages = r#"
            [stage.c]
            bin = "c"
            inputs.x = "x"
            [stage.b]
            bin = "b"
            [stage.a]
            bin = "a"
            outputs.x = "x"
            [stage.d]
            bin = "d"
        "#;
        // b, a and d are ready at once: file order b, a, d; c becomes ready after a, and is
        // declared before everything still waiting.
        assert_eq!(order(stages), ["b", "a", "c", "d"]);
    }

    #[test]
    fn after_adds_an_edge() {
        let stages = "[stage.a]\nbin = \"a\"\nafter = [\"b\"]\n[stage.b]\nbin = \"b\"\n";
        assert_eq!(order(stages), ["b", "a"]);
        let (_, d) = dag(stages).unwrap();
        assert_eq!(d.incoming(0), &[(1, Edge::After)]);
    }

    #[test]
    fn ancestors() {
        let stages =
            "[stage.a]\nbin = \"a\"\noutputs.o = \"a\"\n[stage.b]\nbin = \"b\"\ninputs.i = \"a\"\noutputs.o = \"b\"\n\
                      [stage.c]\nbin = \"c\"\ninputs.i = \"b\"\n[stage.d]\nbin = \"d\"\ninputs.i = \"a\"\n";
        let (_, d) = dag(stages).unwrap();
        assert_eq!(d.with_ancestors(2), BTreeSet::from([0, 1, 2]));
        assert_eq!(d.with_ancestors(3), BTreeSet::from([0, 3]));
        assert_eq!(d.with_ancestors(0), BTreeSet::from([0]));
    }

    #[test]
    fn two_stage_cycle_is_named() {
        let stages = "[stage.a]\nbin = \"a\"\ninputs.i = \"b.out\"\noutputs.o = \"a.out\"\n\
                      [stage.b]\nbin = \"b\"\ninputs.i = \"a.out\"\noutputs.o = \"b.out\"\n";
        assert_eq!(dag(stages).unwrap_err().to_string(), "pipeline.toml: dependency cycle: a -> b -> a");
    }

    #[test]
    fn longer_cycle_behind_a_healthy_stage() {
        let stages = "[stage.ok]\nbin = \"o\"\n\
                      [stage.x]\nbin = \"x\"\nafter = [\"z\"]\n\
                      [stage.y]\nbin = \"y\"\nafter = [\"x\", \"ok\"]\n\
                      [stage.z]\nbin = \"z\"\nafter = [\"y\"]\n";
        assert_eq!(dag(stages).unwrap_err().to_string(), "pipeline.toml: dependency cycle: x -> y -> z -> x");
    }

    #[test]
    fn self_cycles() {
        let stages = "[stage.a]\nbin = \"a\"\ninputs.i = \"f\"\noutputs.o = \"f\"\n";
        // Caught earlier, as an output that is its own stage's input.
        assert!(dag(stages).unwrap_err().to_string().contains("output `o` is `f`, also an input of the same stage"));
        let stages = "[stage.a]\nbin = \"a\"\nafter = [\"a\"]\n";
        assert_eq!(dag(stages).unwrap_err().to_string(), "pipeline.toml: dependency cycle: a -> a");
    }
}
