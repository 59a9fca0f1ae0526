//! The normal-aware 6-D kd-tree of the paper's §3.2 (docs/design.md §3).
//!
//! Plain nearest neighbours pair an arm vertex with the torso right beside it. Here every
//! target point r with unit normal n becomes the key (x, y, z, λ·nx, λ·ny, λ·nz), and a
//! query (a model vertex with its deformed normal) looks for the key nearest in the
//! Euclidean metric of that 6-D space:
//!
//! d² = ‖p − r‖² + λ²·‖n_p − n_r‖²
//!
//! so that a point whose surface faces another way is far even when it is close in space.
//! λ (`normal_weight`, metres per unit of normal difference) defaults to the paper's
//! balance of the normal's range against the size of the cloud ([`default_normal_weight`]).
//!
//! The tree splits on the dimension of largest variance of the keys, at the median, keeps
//! points in leaf buckets stored contiguously, and lives in flat arrays. Queries are exact;
//! a pair may then be rejected by a [`Gate`] on the distance in space or on the angle
//! between normals. Batches run on all cores (`std::thread::scope`).
//!
//! ```
//! use hullcap_kdtree::{BuildOptions, Gate, NormalKdTree};
//! let points = [[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]];
//! let normals = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]];
//! let options = BuildOptions { normal_weight: Some(0.1), ..BuildOptions::default() };
//! let tree = NormalKdTree::build(&points, &normals, &options).unwrap();
//! // A query on point 0 but facing +x pairs with point 1, 1 cm away.
//! let hit = tree.query(&[[0.0, 0.0, 0.0]], &[[1.0, 0.0, 0.0]], &Gate::default(), None).unwrap();
//! assert_eq!(hit[0].index, 1);
//! ```

mod batch;
mod build;
mod descend;
mod error;
mod gate;
mod keys;
mod knn;
mod nearest;
#[cfg(test)]
mod testing;

pub use build::{BuildOptions, DEFAULT_LEAF_SIZE, NormalKdTree};
pub use error::KdTreeError;
pub use gate::Gate;
pub use keys::default_normal_weight;
pub use nearest::Neighbor;
