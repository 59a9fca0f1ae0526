"""Type stubs of the Rust extension module ``hullcap._engine``.

Errors: bad input raises the class of its kind from :mod:`hullcap.errors` (``FitError``
for targets, trees and fits, ``ModelError`` for meshes, rigs and shapes, ``RasterError``
for the image and voxel kernels' images and grids, ``OptionsError``
for ``FitOptions``, ``ArrayError`` for an argument array of the wrong dtype or shape or a
count out of range; each a ``ValueError``), and a fault of the engine itself
``EngineError``."""

from typing import Literal, final

import numpy as np
import numpy.typing as npt

__all__ = ["__version__", "NormalKDTree", "skin_weights", "link_distances", "link_tree_problem", "Rig", "rasterize",
           "coverage", "FitOptions", "Target", "fit", "Shape", "fit_shape", "evaluate", "threads", "classify_cells",
           "carve", "doubtful_points", "background_evidence", "background_distortions", "guided_logit",
           "gaussian_blur", "isosurface"]

__version__: str

def threads() -> int:
    """The threads the engine runs on: ``$HULLCAP_THREADS`` when it is a positive number,
    else every core; at most 256 (a call asking for more gets 256)."""

ArrayLike3 = npt.ArrayLike
"""Anything NumPy turns into an (N, 3) array of real numbers."""

@final
class NormalKDTree:
    """Exact nearest neighbours among target points with normals (the paper's §3.2).

    Each target point ``r`` with unit normal ``n`` is the 6-D key
    ``(x, y, z, λ·nx, λ·ny, λ·nz)``; a query (a point with its normal) finds the key
    nearest in that space, so a point whose surface faces another way counts as far even
    when it is close. The pair is then rejected (index -1) when the points are more than
    ``max_distance`` apart in space or their normals more than ``max_angle`` apart; a
    rejected nearest key is never replaced by a farther one.

    Args:
        points: (N, 3) target points, metres. Any real dtype; copied once if not
            C-contiguous float64.
        normals: (N, 3) target normals, any non-zero length (they are normalised).
        normal_weight: λ, metres per unit of normal difference. Default: the paper's
            balance, λ·π = the diagonal of the points' bounding box.
        leaf_size: most points per leaf bucket.

    Raises:
        ArrayError: wrong shape or dtype, ``leaf_size < 1``.
        FitError: NaN/inf, a zero-length normal, no points, ``normal_weight <= 0``.
    """

    def __init__(
        self,
        points: ArrayLike3,
        normals: ArrayLike3,
        normal_weight: float | None = None,
        leaf_size: int = 16,
    ) -> None: ...
    def query(
        self,
        points: ArrayLike3,
        normals: ArrayLike3,
        max_distance: float = ...,
        max_angle: float = ...,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """The nearest key of each query.

        Args:
            points: (M, 3) query points, metres.
            normals: (M, 3) query normals, any non-zero length.
            max_distance: largest distance in space (metres) of an accepted pair.
            max_angle: largest angle between normals (radians) of an accepted pair.
            threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.

        Returns:
            ``(indices, distances)``: (M,) int64 indices into the tree's points (-1 where
            gated out) and (M,) float64 6-D distances ``sqrt(|Δp|² + λ²|Δn|²)`` (inf
            where gated out).
        """
    def query_k(
        self,
        points: ArrayLike3,
        normals: ArrayLike3,
        k: int,
        max_distance: float = ...,
        max_angle: float = ...,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """The ``k`` nearest keys of each query, nearest first: (M, k) indices and
        distances; gated pairs, and slots past the tree's size, are -1 / inf in place."""
    @property
    def normal_weight(self) -> float:
        """λ, metres per unit of normal difference."""
    @property
    def leaf_size(self) -> int:
        """Most points per leaf bucket."""
    def __len__(self) -> int: ...

def skin_weights(
    vertices: ArrayLike3,
    faces: npt.ArrayLike,
    links: npt.ArrayLike,
    b: float = 40.0,
    k: int = 4,
    groups: list[int] | None = None,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Non-penetrating geodesic skin weights (the paper's §2.2, eq. 1).

    x_ij is the shortest path from vertex i to link j through the mesh edges plus straight
    arcs from a vertex to the closest point of a link that cross no triangle; then
    w_ij = exp(-b·x_ij) normalised over the links, the ``k`` largest kept and renormalised.

    Args:
        vertices: (V, 3) mesh vertices, metres.
        faces: (T, 3) vertex indices of the triangles (a closed, oriented mesh).
        links: (L, 2, 3) link segments (start, end), metres.
        b: decay per metre; larger = sharper bends. 40 m⁻¹ blends over a few cm.
        k: weights kept per vertex; 1 is the rigid segment model.
        groups: for each link, the bone it moves with (structure links share their
            parent's bone; their weights are summed into it). Default: each its own.
        threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.

    Returns:
        ``(links, weights)``: (V, K) int64 bone indices and (V, K) float64 weights, largest
        first, each row summing to 1 (K = min(k, number of bones)).
    """

def link_distances(
    vertices: ArrayLike3,
    faces: npt.ArrayLike,
    links: npt.ArrayLike,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], float, float, float]:
    """The geodesic distances behind ``skin_weights``: (L, V) x_ij, (V, L) direct arc
    lengths (inf where the arc crosses the mesh), and the seconds spent on the
    segment-mesh tests, on building the edge graph and on Dijkstra (all links)."""

def link_tree_problem(
    parents: list[int],
    origins: ArrayLike3,
    dof_links: list[int],
    dof_axes: ArrayLike3,
    dof_limits: npt.ArrayLike,
) -> tuple[int | None, str] | None:
    """The engine's check of a link tree (the one ``Rig`` makes): None when it is sound,
    else (the link at fault, or None when no one link is, and the problem in words).
    Parents come before their children, only link 0 is the root, each link's DOF are
    listed together, axes are non-zero and limits ordered (radians)."""

@final
class Rig:
    """A rigged mesh: link tree, rest mesh (body frame) and K-sparse skin weights."""

    def __init__(
        self,
        parents: list[int],
        origins: ArrayLike3,
        dof_links: list[int],
        dof_axes: ArrayLike3,
        dof_limits: npt.ArrayLike,
        vertices: ArrayLike3,
        normals: ArrayLike3,
        weight_links: npt.ArrayLike,
        weights: npt.ArrayLike,
    ) -> None: ...
    @property
    def n_dofs(self) -> int: ...
    def pose(
        self,
        theta: list[float] | npt.NDArray[np.float64],
        root_rotation: npt.ArrayLike | None = None,
        root_translation: npt.ArrayLike | None = None,
        threads: int | None = None,
    ) -> tuple[
        npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]
    ]:
        """(vertices (V, 3), normals (V, 3), joint centres (L, 3), link rotations (L, 3, 3)),
        world frame: world = R·body + t."""
    def frames(
        self,
        theta: list[float] | npt.NDArray[np.float64],
        root_rotation: npt.ArrayLike | None = None,
        root_translation: npt.ArrayLike | None = None,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(joint centres (L, 3), link rotations (L, 3, 3)) as ``pose`` gives them, without
        posing the mesh."""
    def jacobian(
        self,
        theta: list[float] | npt.NDArray[np.float64],
        root_rotation: npt.ArrayLike | None = None,
        root_translation: npt.ArrayLike | None = None,
        threads: int | None = None,
    ) -> npt.NDArray[np.float64]:
        """(V, 6 + n_dofs, 3) derivatives of the world vertices: (tx, ty, tz, ωx, ωy, ωz,
        θ…), with rotations perturbed as R ← exp([ω]×)·R."""

def rasterize(
    vertices: ArrayLike3,
    faces: npt.ArrayLike,
    width: int,
    height: int,
    near: float = 1e-3,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]]:
    """Z-buffered rasterisation of triangles already projected into an image.

    Args:
        vertices: (V, 3) rows (u, v, z): pixel coordinates (pixel (0, 0) is the centre of
            the top-left pixel) and camera depth in metres.
        faces: (T, 3) vertex indices.
        width, height: image size in pixels.
        near: triangles with a corner at depth <= near are skipped.
        threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.

    Returns:
        ``(depth, face)``: (height, width) float32 depth of the nearest surface (inf where
        none) and int32 index of the triangle seen (-1 where none).
    """

def coverage(
    vertices: ArrayLike3,
    faces: npt.ArrayLike,
    width: int,
    height: int,
    near: float = 1e-3,
    threads: int | None = None,
    closed: bool = False,
) -> npt.NDArray[np.uint8]:
    """The silhouette of triangles already projected into an image: (height, width) uint8,
    1 exactly where ``rasterize`` (same arguments) sees a triangle, 0 elsewhere; cheaper,
    since no depth is computed.

    ``closed``: the triangles bound a solid (every edge in two of them, wound oppositely)
    lying wholly beyond ``near``. A line of sight through such a solid enters it through a
    triangle of one winding in the image and leaves through one of the other, so only the
    triangles of one winding are drawn: the same pixels from half the triangles (short of
    a pixel centre lying exactly on a corner, where rounding decides). An open mesh
    drawn so shows holes."""

@final
class FitOptions:
    """Options of ``fit`` and ``fit_shape``; defaults are the engine's own. Distances in
    metres, angles in radians. Fields can be set; ``replace(**changes)`` returns a checked
    copy, and every value is checked again when a fit uses it (``OptionsError`` naming the
    field)."""

    residual: Literal["point_to_point", "point_to_plane"]
    solver: Literal["lm", "cg"]
    max_distance: float
    """Largest distance of an accepted pair, both directions."""
    max_angle: float
    """Largest angle between the normals of an accepted pair (radians)."""
    sigma_min: float
    """Lower bound of the Lorentzian's robust scale σ (metres)."""
    reverse_weight: float
    """Weight of the hull→model pairs against the model→hull pairs (0 = the paper's
    one-sided energy)."""
    reverse_points: int
    """Hull points that seek a model partner, spread evenly over the target."""
    reverse_vertices: int
    """Model vertices (spread evenly) among which a hull point seeks its partner."""
    model_points: int
    """Model vertices that seek partners when the caller names none (spread evenly)."""
    iterations: int
    tolerance: float
    rounds: int
    hierarchical: bool
    polish: bool
    coarse: int
    """Coarse to fine: the hierarchy's stages pair every ``coarse``-th model point and a
    ``coarse``-th of the hull samples and reverse vertices; the final polish and the
    statistics use them all (1 = every stage on every point; hierarchical fits only)."""
    over_relaxation: float
    """A Levenberg–Marquardt step that goes on in the direction of its stage's last step
    is taken this many times over (at least 1, below 2) when that still lowers the
    energy at the iteration's pairs: ICP's crawl along the hull in fewer re-pairings
    (docs/design.md §4). 1 (the default) = every step as solved, the paper's iteration."""
    inlier_distance: float
    threads: int | None
    def __init__(self, **changes: object) -> None: ...
    def replace(self, **changes: object) -> FitOptions: ...
    def coarsened(self) -> FitOptions:
        """These options at the resolution of the coarse stages: a ``coarse``-th of the
        model points, hull samples and reverse vertices, and ``coarse`` 1; for scoring
        many poses as those stages see them."""
    def to_dict(self) -> dict[str, object]: ...

@final
class Target:
    """A target surface (points with outward normals) indexed for correspondences by the
    normal-aware 6-D kd-tree; ``normal_weight`` is λ (default: the paper's balance)."""

    def __init__(self, points: ArrayLike3, normals: ArrayLike3, normal_weight: float | None = None) -> None: ...
    def __len__(self) -> int: ...
    @property
    def normal_weight(self) -> float: ...

Pose = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]
"""(theta (D,), root rotation (3, 3), root translation (3,))."""

def fit(
    rig: Rig,
    target: Target,
    theta: list[float],
    root_rotation: npt.ArrayLike,
    root_translation: npt.ArrayLike,
    groups: list[list[int]],
    options: FitOptions,
    model_points: list[int] | None = None,
    prior: tuple[list[float], list[float], float] | None = None,
) -> tuple[Pose, dict[str, float]]:
    """Robust articulated ICP from a starting pose; ``groups`` are the DOF indices of each
    hierarchical stage after the root; ``prior``: ``(mean, sigma, prior_distance)`` of a
    Gaussian prior on the joint angles (radians, one per DOF, ``inf`` = none), one
    standard deviation worth ``prior_distance`` metres of every pair. Returns the fitted
    pose and its statistics (iterations, rounds, energy (the data's), inlier_fraction,
    mean_residual, coverage, mean_reverse_residual, sigma)."""

@final
class Shape:
    """A rig whose proportions are parameters: per parameter, the ``(link, (3, 3))``
    stretches, ``(link, (3,))`` shifts and ``(link, (3,))`` centre moves one unit of it
    makes (see ``hullcap._shape``)."""

    def __init__(
        self,
        rig: Rig,
        stretches: list[list[tuple[int, npt.ArrayLike]]],
        shifts: list[list[tuple[int, npt.ArrayLike]]],
        centres: list[list[tuple[int, npt.ArrayLike]]],
    ) -> None: ...
    @property
    def n_params(self) -> int: ...
    def rest(self, shape: list[float]) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(joint centres (L, 3), rest vertices (V, 3)) at ``shape``, body frame."""
    def map_points(self, shape: list[float], links: list[int], points: ArrayLike3) -> npt.NDArray[np.float64]:
        """Rest points bound to ``links`` moved with their link's surface at ``shape``."""

def fit_shape(
    shape: Shape,
    initial_shape: list[float],
    targets: list[Target],
    thetas: list[list[float]],
    root_rotations: list[npt.ArrayLike],
    root_translations: list[npt.ArrayLike],
    prior_sigma: list[float],
    prior_distance: float,
    options: FitOptions,
    model_points: list[int] | None = None,
) -> tuple[npt.NDArray[np.float64], list[Pose], list[dict[str, float]], int]:
    """One shape vector and one pose per target fitted together (Levenberg–Marquardt on
    the sum of the targets' robust energies plus a Gaussian prior on the shape, one
    standard deviation ``prior_sigma[p]`` worth ``prior_distance`` metres of every pair).
    Returns the shape, the poses, each target's statistics and the iterations made."""

def evaluate(
    rig: Rig,
    target: Target,
    thetas: list[list[float]],
    root_rotations: list[npt.ArrayLike],
    root_translations: list[npt.ArrayLike],
    options: FitOptions,
    model_points: list[int] | None = None,
) -> list[dict[str, float]]:
    """The statistics of each pose as ``fit`` reports them, without fitting (fresh
    correspondences both ways), the poses spread over the threads: how a search ranks
    its candidates."""

DistanceImage = npt.ArrayLike | tuple[npt.ArrayLike, int, int, int, int]
"""A whole (height, width) signed distance image, or ``(values, x0, y0, width, height)``:
one given in a box (see :func:`classify_cells`)."""

CarveView = tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, float, DistanceImage,
                  DistanceImage | None]
"""One camera's view as the hull's carving reads it: ``(K, dist, R, t, focal, signed,
prior)`` (see :func:`classify_cells`)."""

def classify_cells(
    centres: ArrayLike3,
    radius: float,
    views: list[CarveView],
    tolerance: int,
    min_views: int,
    threads: int | None = None,
) -> npt.NDArray[np.uint8]:
    """The visual hull's carving test for each cell: 0 out, 1 in, 2 to be split.

    Each centre is projected into each view (distortion included) and the view's signed
    distance image (pixels, positive inside the silhouette) is read at the nearest pixel
    (ties to even). A view leaves the cell out when that value is below minus the cell's
    image radius, ``focal · radius / depth``, and its prior likewise. Views that do not see
    the centre (behind the camera, depth at most 1e-6 m, or outside the image) neither
    leave it out nor have it inside. Out: more than `tolerance` views leave it out, or
    one does and some view's prior leaves it out too. Otherwise, for ``radius > 0``: in
    when every view has it inside by more than its image radius, else split; for
    ``radius == 0`` (the finest level, the centre decides): in when at least `min_views`
    views see it, else out.

    Args:
        centres: (N, 3) world points, the cells' centres.
        radius: the radius (metres) of the sphere around each cell; 0 at the finest level.
        views: per camera ``(K, dist, R, t, focal, signed, prior)``: the camera as
            :class:`hullcap.Camera` holds it ((3, 3) intrinsics, 5 distortion coefficients
            k1, k2, p1, p2, k3, (3, 3) rotation and (3,) translation from the world), the
            larger focal length in pixels, the signed distance image and the prior's (of
            the same image size) or ``None``. A distance image is a whole (height, width)
            float32 array, or ``(values, x0, y0, width, height)``: the (h, w) values of a
            box at column `x0`, row `y0` of a `width` × `height` image, beyond which the
            image holds minus the Chebyshev distance (pixels) to the box; an empty box
            (h or w 0) is an empty silhouette, every pixel infinitely far outside.
        tolerance: how many views may leave a cell out and be overruled.
        min_views: at the finest level, how many views must see a cell to keep it.
        threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.
    """

def carve(
    lo: npt.ArrayLike,
    voxel_size: float,
    fine: tuple[int, int, int] | list[int],
    levels: int,
    views: list[CarveView],
    tolerance: int,
    min_views: int,
    threads: int | None = None,
) -> tuple[list[int], npt.NDArray[np.bool_], int]:
    """The visual hull's coarse-to-fine carving (docs/design.md §7).

    The box of ``fine`` voxels of side `voxel_size` starting at `lo` is covered by cells of
    ``2**levels`` voxels; each level's cells are classified as :func:`classify_cells` does
    (radius ``side · √3 / 2``, 0 at the finest level), the cells in are kept whole and the
    cells to be split are split in eight, down to single voxels.

    Args:
        lo: (3,) the first corner of the box (metres).
        voxel_size: the finest voxel's side (metres).
        fine: the box's size in finest voxels per axis (each at least 1).
        levels: how many times the coarsest cells are halved.
        views, tolerance, min_views, threads: as :func:`classify_cells`.

    Returns:
        ``(first, occupancy, tested)``: the finest-voxel index of the occupancy's first
        voxel (it keeps two empty voxels all round, so it may be negative), the boolean
        occupancy, and how many cells were tested over all levels. Nothing kept gives a
        1 × 1 × 1 empty occupancy at index (0, 0, 0).
    """

DoubtView = tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike, npt.ArrayLike | None]
"""One camera's view as :func:`doubtful_points` reads it: ``(K, dist, R, t, mask, unsure)``,
the (H, W) mask (> 0 subject) and where its verdict of background was not sure (None: sure
everywhere)."""

def doubtful_points(
    points: ArrayLike3,
    views: list[DoubtView],
    min_views: int,
    threads: int | None = None,
) -> npt.NDArray[np.bool_]:
    """For each point, whether at least `min_views` views leave it out of their
    silhouettes and none of them was sure of the background there (docs/design.md §7).

    Each point is projected into each view (distortion included) and read at the nearest
    pixel (ties to even), as the carving reads it; views that do not see it (behind the
    camera, or outside the image) say nothing of it.

    Args:
        points: (N, 3) world points.
        views: per camera ``(K, dist, R, t, mask, unsure)``: the camera as
            :class:`hullcap.Camera` holds it, its (height, width) uint8 silhouette
            (non-zero keeps a pixel) and a bool image of the same size, true where its
            verdict of background was not sure, or ``None`` for sure everywhere.
        min_views: how many views must leave a point out.
        threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.
    """

def background_evidence(
    image: npt.ArrayLike,
    planes: npt.ArrayLike,
    rule: tuple[float, float, float, float],
    threads: int | None = None,
) -> npt.NDArray[np.float32]:
    """Horprasert's background test of one colour image, in one pass: per pixel, the
    normalised chromaticity distortion less ``rule[0]`` (the chromaticity threshold), or
    ``rule[3]`` where the brightness distortion α lies below ``rule[1]`` (the darkest
    shadow) or above ``rule[2]`` (the brightest highlight). The arithmetic is the former
    NumPy steps of ``StatisticalBackground`` one for one in single precision, so the
    values are theirs to the bit.

    Args:
        image: (H, W, 3) uint8, channels in the order of the model's.
        planes: (8, H, W) float32, the model's per-pixel constants: 1/s of each channel,
            E/s of each channel, ‖E/s‖² (positive), 1/(the spread of CD).
        rule: (chromaticity, darkest_shadow, brightest_highlight, foreground evidence).
        threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.

    Returns:
        (H, W) float32 evidence, > 0 for foreground.
    """

def background_distortions(
    image: npt.ArrayLike,
    planes: npt.ArrayLike,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """(α, CD): the brightness and chromaticity distortions of each pixel of `image`
    against the model of ``background_evidence``'s `planes` (whose last plane is not
    read), each (H, W) float32, CD not normalised."""

def guided_logit(
    evidence: npt.ArrayLike,
    image: npt.ArrayLike,
    origin: tuple[int, int],
    ramp: npt.ArrayLike,
    weights: tuple[float, float, float, float, float, float],
    colours: tuple[npt.ArrayLike, int] | None = None,
) -> npt.NDArray[np.float32]:
    """The log-odds of the model-guided silhouettes (``hullcap._guided``) over a window of
    one view, in one pass: per pixel, the evidence clipped into ``weights[0]..weights[1]``
    (times ``weights[2]`` where it is not positive), plus ``weights[3]`` times the prior's
    ramp, plus ``weights[4]`` times the colour log-ratio clipped into ±``weights[5]``.
    The arithmetic is NumPy's steps one for one in single precision, so the values are
    theirs to the bit.

    Args:
        evidence: (H, W) float32, the background test's evidence of the whole view.
        image: (H, W, 3) uint8, the view's image.
        origin: (row, column) of the window's first pixel.
        ramp: (h, w) float32, the prior's ramp over the window (which it sizes).
        weights: (evidence_min, evidence_max, background, prior, colour, colour_limit).
        colours: ``(table, bins)``: the log-ratio of each colour bin, bins³ float32
            indexed (c0·bins + c1)·bins + c2 by the bins (value·bins // 256) of a pixel's
            channels in the image's order; ``None`` leaves the colour term out.

    Returns:
        (h, w) float32 log-odds, > 0 for the subject.

    Raises:
        ArrayError: an array of the wrong type or shape.
        RasterError: the window does not lie in the image, the table does not hold bins³
            values, or the bounds are NaN or out of order.
    """

def gaussian_blur(
    values: npt.ArrayLike,
    sigma: float,
    threads: int | None = None,
) -> npt.NDArray[np.float32]:
    """A 3-D grid of small whole numbers (an occupancy) convolved with a Gaussian of
    `sigma` voxels cut at 3σ, zero beyond the grid: SciPy's ``gaussian_filter(values,
    sigma, mode="constant", truncate=3.0)`` in single precision, exactly 0 where no
    non-zero value is within reach. The work grows with the rows some non-zero value
    reaches, not with the grid.

    Args:
        values: (nx, ny, nz) array, converted to uint8 (booleans are 0 and 1).
        sigma: the Gaussian's standard deviation in voxels, in (0, 100].
        threads: worker threads; ``None`` = $HULLCAP_THREADS if set, else all cores.

    Returns:
        (nx, ny, nz) float32.
    """

def isosurface(
    field: npt.ArrayLike,
    level: float,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """The closed triangle mesh where a 3-D field crosses `level` (marching cubes whose
    polygons are worked out from each cube's faces; see docs/design.md §7).

    A grid point is above when its value exceeds `level`; each grid edge between an above
    point and one that is not holds a vertex (linear interpolation). A face of a cube with
    its above corners on a diagonal joins them when the bilinear interpolant's saddle is
    above `level`. The mesh is closed wherever the surface does not reach the grid's border.

    Args:
        field: (nx, ny, nz) values, at least 2 per axis (converted to float32).
        level: the value of the surface.
        threads: worker threads, each marching a run of slabs along the first axis;
            ``None`` = $HULLCAP_THREADS if set, else all cores. The mesh is the same, in
            the same order, on any number.

    Returns:
        ``(vertices, faces, normals)``: (V, 3) positions in grid units (index (i, j, k)
        is the point (i, j, k)), (T, 3) vertex indices wound counter-clockwise seen from
        the lower values, and (V, 3) unit normals pointing towards the lower values (the
        field's gradient negated: along the vertex's edge the difference of its two
        values, across it central differences interpolated between the edge's ends).
    """
