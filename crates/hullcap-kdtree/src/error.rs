//! Errors of the kd-tree: invalid input, named by array and row.

/// What can go wrong building or querying a [`crate::NormalKdTree`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KdTreeError {
    /// The tree was given no points.
    #[error("cannot build a kd-tree from zero points")]
    Empty,
    /// Two arrays that must have one row per point have different lengths.
    #[error("{array} has {got} rows but {expected_from} has {expected}")]
    LengthMismatch {
        /// The array at fault.
        array: &'static str,
        /// Its number of rows.
        got: usize,
        /// The array it must match.
        expected_from: &'static str,
        /// That array's number of rows.
        expected: usize,
    },
    /// A coordinate or normal component is NaN or infinite.
    #[error("{array}[{row}] is not finite")]
    NotFinite {
        /// The array at fault.
        array: &'static str,
        /// The first bad row.
        row: usize,
    },
    /// A normal has zero length and cannot be normalised.
    #[error("{array}[{row}] has zero length; normals must be non-zero")]
    ZeroNormal {
        /// The array at fault.
        array: &'static str,
        /// The first bad row.
        row: usize,
    },
    /// A parameter is outside its valid range.
    #[error("{name} must be {requirement}, got {value}")]
    BadParameter {
        /// The parameter's name.
        name: &'static str,
        /// What it must be.
        requirement: &'static str,
        /// What it was.
        value: f64,
    },
    /// The answers of a batch (queries × answers each) would not fit in memory.
    #[error("{queries} queries of {width} answers each do not fit in memory")]
    AnswersTooLarge {
        /// The queries of the batch.
        queries: usize,
        /// The answers of each.
        width: usize,
    },
    /// More points than the tree's 32-bit indices can hold.
    #[error("too many points ({0}); the kd-tree holds at most 2^32 - 1")]
    TooMany(usize),
    /// A worker thread panicked (a bug in the engine, reported instead of aborting).
    #[error(transparent)]
    Worker(#[from] hullcap_core::WorkerPanicked),
}
