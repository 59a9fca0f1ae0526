//! Why a fit was refused.

use hullcap_body::BodyError;
use hullcap_core::WorkerPanicked;
use hullcap_kdtree::KdTreeError;

/// Errors of the fitting engine.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IcpError {
    /// The body model refused the pose (wrong length, not finite, bad rotation).
    #[error(transparent)]
    Body(#[from] BodyError),
    /// The target surface could not be indexed.
    #[error(transparent)]
    Target(#[from] KdTreeError),
    /// A parameter outside its allowed range.
    #[error("{name} must be {requirement}, got {value}")]
    BadParameter {
        /// The option's name.
        name: &'static str,
        /// What it must satisfy.
        requirement: &'static str,
        /// What it was.
        value: f64,
    },
    /// A model point or a DOF index that does not exist.
    #[error("{what} index {index} out of range (0..{bound})")]
    BadIndex {
        /// What kind of index.
        what: &'static str,
        /// The index given.
        index: usize,
        /// The number of items.
        bound: usize,
    },
    /// A worker thread panicked.
    #[error(transparent)]
    Worker(#[from] WorkerPanicked),
}
