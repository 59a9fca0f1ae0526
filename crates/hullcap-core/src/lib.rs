//! Pieces shared by the hullcap engine crates.
//!
//! Only what two or more engine crates need lives here: the scoped-thread chunking that
//! every parallel loop of the engine goes through, and the error it reports when a worker
//! thread panics (a panic never aborts the process and never crosses into Python).

mod parallel;

pub use parallel::{WorkerPanicked, for_each_chunk_mut, resolve_threads};
