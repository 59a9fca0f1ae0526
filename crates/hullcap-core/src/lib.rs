//! Pieces shared by the hullcap engine crates.
//!
//! Only what two or more engine crates need lives here: the scoped-thread chunking that
//! every parallel loop of the engine goes through, the team of threads a long stretch of
//! such loops can keep ([`with_workers`]), and the error they report when a worker thread
//! panics (a panic never aborts the process and never crosses into Python).

mod parallel;
mod team;

pub use parallel::{WorkerPanicked, for_each_chunk_mut, resolve_threads};
pub use team::with_workers;
