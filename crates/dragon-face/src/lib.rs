//! dragon-face: a deterministic synthetic film-style creature face rig and its hand-keyed
//! animation corpus, shaped like the data of Bailey et al. 2016 (742 rig controls, eight
//! expression labels, 3,745 usable frames at 24 fps, plus bad takes to exclude).
//!
//! ```
//! use reprise_dragon_face::{generate_corpus, DragonRig};
//! let rig = DragonRig::new(7);
//! let corpus = generate_corpus(&rig, 7);
//! let mut mesh = vec![0.0; 3 * rig.vertex_count()];
//! rig.evaluate(corpus.takes[0].frame(0), &mut mesh);
//! assert_eq!(corpus.good_frames("neutral"), 700);
//! ```
//!
//! Pure library: no file I/O. Frame: cm, +y up, +z forward, `L` = the character's left (+x).

mod blendshapes;
mod controls;
mod corpus;
mod keys;
mod labels;
mod lattice;
mod layers;
mod math;
mod mesh;
mod parts;
mod poses;
mod rig;
mod skinning;
mod touchups;

pub use controls::{ControlSpec, Unit};
pub use corpus::{
    generate_corpus, generate_corpus_scaled, Corpus, Take, TakeKind, BAD_RANGE_FRAMES, FPS, GOOD_FRAME_BUDGET, LABELS,
};
pub use labels::labels_toml;
pub use rig::DragonRig;
