//! Image-space and voxel kernels: z-buffered rasterisation of triangle meshes already
//! projected to pixels, the background test of silhouettes, and the visual hull: carving,
//! blur and surface.
//!
//! The renderer of synthetic sequences (`hullcap._synth`) projects a mesh into each camera
//! (with its distortion) and hands the engine pixel coordinates and camera depths; the
//! engine returns, per pixel, the depth of the nearest surface and the triangle seen
//! there; shading and pictures are made from those in Python. Where only the silhouette
//! is wanted (the tracker's predicted model, every view of every frame), [`coverage`]
//! marks the same pixels without computing depths.
//!
//! [`background_evidence`] is Horprasert's statistical background test of one camera's
//! image (`hullcap._silhouette`), its per-pixel arithmetic in one pass; [`guided_logit`]
//! sums that evidence with the predicted model's prior and the subject's colours around
//! the predicted person (`hullcap._guided`).
//!
//! Pixel (0, 0) is the centre of the top-left pixel (OpenCV's convention). A pixel is
//! covered when its centre lies inside the triangle (edges shared by two triangles are
//! owned by one of them, by the top-left rule). Depth is interpolated
//! perspective-correctly (1/z is linear in the image). Triangles with a corner at or
//! behind the camera's near plane are skipped, not clipped.
//!
//! The visual hull (`hullcap._hull`) is made here too. [`carve`] descends coarse to fine:
//! [`classify_cells`] projects each cell's centre into every view (with distortion), reads
//! the view's distance image there and decides whether the cell is out, in or to be split,
//! in one parallel pass over a level's cells. [`gaussian_blur`] smooths the occupancy it
//! returns and [`isosurface`] turns that into a closed triangle mesh. [`doubtful_points`]
//! tells which points of that mesh were cut by views that were all unsure of it.

mod background;
mod carve;
mod guided;
mod isosurface;
mod raster;
mod smooth;
mod whole;

pub use background::{BackgroundPlanes, EvidenceRule, background_distortions, background_evidence};
pub use carve::{
    BoxedDistance, Camera, CarveView, Carved, CutView, Verdict, carve, classify_cells,
    doubtful_points,
};
pub use guided::{ColourTable, LogitWeights, Window, guided_logit};
pub use isosurface::{Isosurface, isosurface};
pub use raster::{RasterError, Rendered, coverage, rasterize};
pub use smooth::gaussian_blur;
