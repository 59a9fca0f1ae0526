//! Errors of the body model, naming the array, row or DOF at fault.

/// What can go wrong building or posing a body model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BodyError {
    /// The link tree is malformed.
    #[error("link {link}: {problem}")]
    BadLink {
        /// Index of the link at fault.
        link: usize,
        /// What is wrong with it.
        problem: String,
    },
    /// An array has the wrong number of rows.
    #[error("{array} has {got} entries, expected {expected}")]
    WrongLength {
        /// The array at fault.
        array: &'static str,
        /// Its length.
        got: usize,
        /// The length it must have.
        expected: usize,
    },
    /// A value is NaN or infinite.
    #[error("{array}[{row}] is not finite")]
    NotFinite {
        /// The array at fault.
        array: &'static str,
        /// The first bad row.
        row: usize,
    },
    /// An index points outside its target array.
    #[error("{array}[{row}] = {index} is out of range (must be below {bound})")]
    IndexOutOfRange {
        /// The array at fault.
        array: &'static str,
        /// The first bad row.
        row: usize,
        /// The bad index.
        index: i64,
        /// The exclusive upper bound.
        bound: usize,
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
    /// The root rotation is not a rotation matrix.
    #[error("root_rotation is not a rotation (|RᵀR − I| = {deviation:.3e}, det = {det:.6})")]
    NotARotation {
        /// Largest deviation of RᵀR from the identity.
        deviation: f64,
        /// Its determinant.
        det: f64,
    },
    /// A worker thread panicked (an engine bug, reported instead of aborting).
    #[error(transparent)]
    Worker(#[from] hullcap_core::WorkerPanicked),
}

/// Checks that every value of `rows` is finite.
pub(crate) fn check_finite<const N: usize>(
    rows: &[[f64; N]],
    array: &'static str,
) -> Result<(), BodyError> {
    match rows.iter().position(|r| !r.iter().all(|x| x.is_finite())) {
        Some(row) => Err(BodyError::NotFinite { array, row }),
        None => Ok(()),
    }
}
