//! Characters driven live (the paper's *interactive* applications, §6): every system of
//! the transition benchmark — reprise (tuned and the paper's), Motion Graphs, motion
//! matching, the crossfade — as a [`systems::Character`] that takes [`command::LiveCommand`]s
//! and makes one frame per step, all loaded once from a pipeline's artifacts
//! ([`world::World`]); a [`session::Session`] drives several side by side and records what
//! it was given, and [`session::replay`] reproduces it bit for bit; [`game`] is the
//! paper's Tic-Tac-Toe, whose reactions drive a session. No networking: the
//! server (`reprise-serve`) and the tests drive sessions.
#![warn(missing_docs)]

pub mod command;
pub mod game;
pub mod session;
pub mod systems;
pub mod world;
