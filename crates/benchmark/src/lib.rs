//! The transition benchmark's vocabulary and verdicts, with no I/O.
//!
//! - [`systems`]: the systems compared, one row each ([`systems::SYSTEMS`]).
//! - [`metrics`]: every metric the benchmark reports, one row each ([`metrics::CATALOGUE`]):
//!   its id, unit, which way is better, over what it is averaged, and its definition.
//! - [`verdict`]: the metric rows the evaluate stage writes ([`Metric`]) and the
//!   conclusions read off them once ([`verdict::Conclusions`]), for every renderer.
//!
//! A new metric is one row in the catalogue plus its measurement; a new system one row in
//! [`systems::SYSTEMS`] plus its answers.

pub mod metrics;
pub mod systems;
pub mod verdict;

pub use metrics::{Direction, MetricDef, Per};
pub use systems::SystemDef;
pub use verdict::{Conclusions, Metric, Ranking, Verdict};
