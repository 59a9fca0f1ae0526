//! Image-space kernels: z-buffered rasterisation of triangle meshes already projected to
//! pixels, and images sampled at the projections of world points.
//!
//! The renderer of synthetic sequences (`hullcap._synth`) projects a mesh into each camera
//! (with its distortion) and hands the engine pixel coordinates and camera depths; the
//! engine returns, per pixel, the depth of the nearest surface and the triangle seen
//! there. Silhouettes, shading and pictures are made from those in Python.
//!
//! Pixel (0, 0) is the centre of the top-left pixel (OpenCV's convention). A pixel is
//! covered when its centre lies inside the triangle (edges shared by two triangles are
//! owned by one of them, by the top-left rule). Depth is interpolated
//! perspective-correctly (1/z is linear in the image). Triangles with a corner at or
//! behind the camera's near plane are skipped, not clipped.

//!
//! The visual hull (`hullcap._hull`) carves coarse to fine: [`classify_cells`] projects
//! each cell's centre into every view (with distortion), reads the view's distance image
//! there and decides whether the cell is out, in or to be split, in one parallel pass over
//! the cells.

mod carve;
mod raster;

pub use carve::{Camera, CarveView, Verdict, classify_cells};
pub use raster::{RasterError, Rendered, rasterize};
