//! The systems the transition benchmark compares.

/// One system: its id in the answers artifacts and the metrics table, and how the report
/// names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SystemDef {
    /// Id in `transition_answers.system` and `metrics.system`.
    pub id: &'static str,
    /// Name in the report.
    pub shown: &'static str,
    /// Whether it answers differently under another seed (it then has reseeded curves and a
    /// variety; a system without a seed answers the same every time).
    pub seeded: bool,
    /// What it is, in one sentence for the report.
    pub about: &'static str,
}

/// Every system, the method under test first: every other system is paired with it.
pub const SYSTEMS: [SystemDef; 5] = [
    SystemDef {
        id: "reprise",
        shown: "reprise",
        seeded: true,
        about: "one GPLVM per label, bridges between them, a particle driven by IDLE / TRANSITION commands, \
                with every improvement of the ablation on",
    },
    SystemDef {
        id: "reprise-paper",
        shown: "reprise (paper)",
        seeded: true,
        about: "the same models and bridges, the particle driven as the paper describes (fixed random force, \
                the nearest bridge, idling where it lands)",
    },
    SystemDef {
        id: "motion-graphs",
        shown: "Motion Graphs",
        seeded: true,
        about: "Kovar, Gleicher & Pighin's graph of training frames with blended transitions, a near-shortest path",
    },
    SystemDef {
        id: "motion-matching",
        shown: "Motion matching",
        seeded: false,
        about: "a search of the target label's frames every search interval, inertialized",
    },
    SystemDef {
        id: "crossfade",
        shown: "Crossfade",
        seeded: false,
        about: "a blend from the start pose into the nearest frame of the target label",
    },
];

/// The seed offset of a seeded system's second answer to each request: the benchmark
/// answers every request under its seed and again under seed + `RESEED` (the reseeded
/// curves the variety metric compares), and a replayed session is replayed again under
/// its recording's seed + `RESEED`.
pub const RESEED: u64 = 1_000_003;

/// The ablation: the paper's method with one improvement on (`reprise-paper-<name>`, one
/// per improvement of the synthesis engine's `Method::IMPROVEMENTS`, in its order). They
/// answer the same requests and are measured by the same code, and are shown in the
/// ablation table beside `reprise-paper` (none on) and `reprise` (all on), not in the
/// verdicts.
pub const ABLATION: [SystemDef; 3] = [
    SystemDef {
        id: "reprise-paper-live-idle",
        shown: "paper + live-idle",
        seeded: false,
        about: "the paper's method, the idle's random force and drag set from each label's training frames",
    },
    SystemDef {
        id: "reprise-paper-landing-choice",
        shown: "paper + landing-choice",
        seeded: false,
        about: "the paper's method, TRANSITION taking the bridge of least travel-plus-landing time",
    },
    SystemDef {
        id: "reprise-paper-settle",
        shown: "paper + settle",
        seeded: false,
        about: "the paper's method, the particle moving to a training pose of the target after the switch",
    },
];

/// The system with id `id`, if the benchmark knows it (a compared system or an ablation).
pub fn find(id: &str) -> Option<&'static SystemDef> {
    SYSTEMS.iter().chain(&ABLATION).find(|s| s.id == id)
}

/// How the report names system `id` (the id itself for a system it does not know).
pub fn shown(id: &str) -> &str {
    find(id).map_or(id, |s| s.shown)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_and_names_are_unique_and_reprise_comes_first() {
        assert_eq!(SYSTEMS[0].id, "reprise");
        let all: Vec<&SystemDef> = SYSTEMS.iter().chain(&ABLATION).collect();
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert!(a.id != b.id && a.shown != b.shown, "{a:?} {b:?}");
            }
        }
        assert_eq!(shown("motion-graphs"), "Motion Graphs");
        assert_eq!(shown("someone-else"), "someone-else");
    }
}
