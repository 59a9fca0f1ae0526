//! The target surface: points with unit normals and their 6-D kd-tree.

use crate::IcpError;
use hullcap_kdtree::{BuildOptions, NormalKdTree};

/// What the model is fitted to: the visual hull's vertices and outward normals.
#[derive(Debug, Clone)]
pub struct Target {
    pub(crate) tree: NormalKdTree,
    pub(crate) points: Vec<[f64; 3]>,
    pub(crate) normals: Vec<[f64; 3]>,
}

impl Target {
    /// Indexes `points` with `normals` (any non-zero length). `normal_weight`: λ of the
    /// 6-D keys (default: the paper's balance, bounding-box diagonal / π).
    pub fn new(
        points: &[[f64; 3]],
        normals: &[[f64; 3]],
        normal_weight: Option<f64>,
    ) -> Result<Self, IcpError> {
        let options = BuildOptions {
            normal_weight,
            ..BuildOptions::default()
        };
        let tree = NormalKdTree::build(points, normals, &options)?;
        let normals = normals
            .iter()
            .map(|n| {
                let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                [n[0] / l, n[1] / l, n[2] / l]
            })
            .collect();
        Ok(Target {
            tree,
            points: points.to_vec(),
            normals,
        })
    }

    /// Number of target points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no points (never: construction refuses that).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// About `count` target indices spread evenly over the points (every n-th).
    pub fn samples(&self, count: usize) -> Vec<u32> {
        crate::spread(self.points.len(), count)
    }

    /// λ of the kd-tree's keys.
    pub fn normal_weight(&self) -> f64 {
        self.tree.normal_weight()
    }
}
