"""A run's results: per-frame poses, joints and fit quality (the files they are written to
and read from are :mod:`hullcap.export`'s).

Every frame has a status: ``good`` (the fit explains the hull as well as the recent
frames did), ``recovered`` (it did after a search from the hull itself), or ``failed``.
Once the run is over, each joint of each fitted frame gets a confidence from evidence the
prediction did not make (:mod:`hullcap._confidence`); a joint below the bar is
``uncertain``, and so is its frame (:meth:`TrackingResult.judge`). Failed frames hold
NaN and are left out of ``joints.csv`` unless the outputs are asked to interpolate them,
in which case they are filled from their neighbours and marked ``interpolated``. Joint
trajectories can be low-pass filtered without lag for analysis; the raw results are
always kept.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from hullcap._body import BodyModel
from hullcap._confidence import UNEXPLAINED_ABOVE, UNSURE_BELOW, confidence
from hullcap._fitting import FitResult, PoseParameters
from hullcap.errors import OptionsError, ResultsError

__all__ = ["GOOD", "RECOVERED", "FAILED", "INTERPOLATED", "UNCERTAIN", "STATUS_NAMES", "TrackingResult",
           "smooth_joints", "check_cutoff"]

GOOD, RECOVERED, FAILED, INTERPOLATED, UNCERTAIN = 0, 1, 2, 3, 4
STATUS_NAMES = ("good", "recovered", "failed", "interpolated", "uncertain")
"""What ``status`` values mean (``pose.npz`` and the ``status`` column of ``joints.csv``)."""

STATS = ("energy", "inlier_fraction", "mean_residual", "coverage", "mean_reverse_residual")
"""Per-frame fit statistics kept from each frame's :class:`~hullcap._fitting.FitResult`."""

LIMIT_TOLERANCE = np.radians(0.5)
"""How near one of its limits a joint angle lies to count as held there (radians)."""
LIMIT_SIDES = {"lower": -1, "upper": 1}
"""The values :meth:`TrackingResult.at_limits` gives an angle held at each limit."""


@dataclass
class TrackingResult:
    """Per-frame results of a run (F frames); failed frames hold NaN.

    Attributes:
        model: the subject's model.
        fps: frame rate.
        theta (F, D), root_rotation (F, 3, 3), root_translation (F, 3): the poses.
        joints: (F, J, 3) joint positions, world metres.
        status: (F,) uint8, see :data:`STATUS_NAMES`.
        energy, inlier_fraction, mean_residual, coverage, mean_reverse_residual: (F,) the
            fit statistics (:class:`~hullcap._fitting.FitResult`).
        iterations: (F,) ICP iterations spent on the frame, searches included.
        link_counts: (F, L, 4) each frame's per-link counts (``FitResult.link_counts``).
        bar: (F,) the quality a fit of the frame had to reach to stand without a search:
            the tracker's floor when it judged the frame (``TrackerOptions.quality_margin``
            below the median quality of the recent good frames, never under
            ``min_quality``); NaN where no fit was judged.
        key_point_offset: (F, J) metres from each fitted joint to the learned segmenter's
            key point of it (:func:`hullcap._confidence.key_point_offsets`); NaN where not
            measured.
        joint_status: (F, J) uint8, each joint's status (:data:`STATUS_NAMES`): its frame's,
            or ``uncertain`` where :meth:`judge` found its confidence too low.
        unexplained: (F,) the share of the background test's foreground the fit leaves
            unexplained, the median over the views
            (:func:`hullcap._confidence.unexplained_share`); NaN where not measured (the
            learned segmenter's key points judge the joints instead, or the masks were given).
        seconds: seconds spent per stage of tracking the sequence (silhouettes, hull, fit), and
            on the subject's model (its frames and calibration pass included: "subject").
        subject_frame: the frame the subject's model was built from (or a given model
            placed at): the first whose hull it explains; tracking starts there. -1 where
            unknown (a ``pose.npz`` from before it was kept).
    """

    model: BodyModel
    fps: float
    theta: np.ndarray
    root_rotation: np.ndarray
    root_translation: np.ndarray
    joints: np.ndarray
    status: np.ndarray
    energy: np.ndarray
    inlier_fraction: np.ndarray
    mean_residual: np.ndarray
    coverage: np.ndarray
    mean_reverse_residual: np.ndarray
    iterations: np.ndarray
    link_counts: np.ndarray
    bar: np.ndarray
    key_point_offset: np.ndarray
    joint_status: np.ndarray
    unexplained: np.ndarray
    seconds: dict = field(default_factory=dict)
    subject_frame: int = -1

    @property
    def failed(self) -> np.ndarray:
        """(F,) bool: frames without a pose."""
        return self.status == FAILED

    @property
    def confidence(self) -> np.ndarray:
        """(F, J) each joint's confidence in [0, 1], NaN where it is not judged (no key
        points seen, a frame without a fitted pose): :func:`hullcap._confidence.confidence`."""
        fitted = ~np.isin(self.status, (FAILED, INTERPOLATED))
        return confidence(self.model.joint_names, self.key_point_offset, fitted)

    def judge(self) -> None:
        """Each joint of a good or recovered frame whose :attr:`confidence` is below
        :data:`~hullcap._confidence.UNSURE_BELOW` becomes ``uncertain`` in
        :attr:`joint_status`, and its frame in :attr:`status`; every joint of a frame
        that leaves more than :data:`~hullcap._confidence.UNEXPLAINED_ABOVE` of the
        background test's foreground :attr:`unexplained` too; the others keep their
        frame's status. Done once the run is over (the steady offsets are the take's); a
        second time changes nothing."""
        unsure = (self.confidence < UNSURE_BELOW) | (self.unexplained > UNEXPLAINED_ABOVE)[:, None]
        claimed = np.isin(self.status, (GOOD, RECOVERED))
        self.joint_status[claimed] = self.status[claimed, None]
        self.joint_status[claimed[:, None] & unsure] = UNCERTAIN
        self.status[claimed & unsure.any(axis=1)] = UNCERTAIN

    def joints_kept(self, drop_uncertain: bool = False) -> np.ndarray:
        """(F, J, 3) :attr:`joints`, with those marked uncertain NaN when `drop_uncertain`
        (written as gaps)."""
        if not drop_uncertain:
            return self.joints
        return np.where((self.joint_status == UNCERTAIN)[..., None], np.nan, self.joints)

    @property
    def quality(self) -> np.ndarray:
        """(F,) how much of each frame's hull the fit explains both ways:
        ½(inlier fraction + coverage), 1 = every point within the inlier distance."""
        return 0.5 * (self.inlier_fraction + self.coverage)

    def at_limits(self) -> np.ndarray:
        """(F, D) int8: −1 where a frame's joint angle lies at its lower limit in the
        model, +1 at its upper, 0 elsewhere and in failed frames. An angle held at a
        limit is the model's bound, not a measurement: the fit would have turned the
        joint further. A DOF whose range starts at 0 (an elbow's or a knee's flexion: a
        limb that does not bend backwards) held at 0 is the limb held straight, the
        body's own stop, and counts as free."""
        lo, hi = self.model.link_model.dof_limits.T
        fitted = np.isfinite(self.theta)
        out = np.zeros(self.theta.shape, np.int8)
        with np.errstate(invalid="ignore"):
            out[fitted & (self.theta <= lo + LIMIT_TOLERANCE) & (lo != 0)] = -1
            out[fitted & (self.theta >= hi - LIMIT_TOLERANCE)] = 1
        return out

    def limits_held(self, at_limits: np.ndarray | None = None) -> list[tuple[str, str, int]]:
        """``(dof, "lower" | "upper", frames)`` of every joint angle held at one of its
        limits in some frame (:meth:`at_limits`, or `at_limits` when given), most frames
        first."""
        held = self.at_limits() if at_limits is None else at_limits
        found = [(name, side, int((held[:, d] == sign).sum()))
                 for d, name in enumerate(self.model.dof_names) for side, sign in LIMIT_SIDES.items()]
        return sorted((f for f in found if f[2]), key=lambda f: -f[2])

    @classmethod
    def empty(cls, model: BodyModel, n: int, fps: float) -> TrackingResult:
        nan = lambda *shape: np.full((n, *shape), np.nan)  # noqa: E731
        joints = len(model.joint_names)
        return cls(model, fps, nan(model.n_dofs), nan(3, 3), nan(3), nan(joints, 3),
                   np.full(n, FAILED, np.uint8), *(nan() for _ in STATS), np.zeros(n, np.int64),
                   np.zeros((n, len(model.link_model.names), 4), np.int64), nan(), nan(joints),
                   np.full((n, joints), FAILED, np.uint8), nan())

    @classmethod
    def from_arrays(cls, model: BodyModel, a) -> TrackingResult:
        """A result from the arrays of :meth:`arrays` (a checkpoint, or ``pose.npz``, whose
        joints are recomputed from the model); ResultsError naming the array that is not
        what `model` and the number of frames make it."""
        theta = _checked_array(a, "theta", None, "fiu")
        if theta.ndim != 2 or theta.shape[1] != model.n_dofs:
            raise ResultsError(f"theta has shape {theta.shape}, not (frames, {model.n_dofs}) for this model")
        n, links, joints = len(theta), len(model.link_model.names), len(model.joint_names)

        def array(key, shape, kinds, default=None):
            return _checked_array(a, key, (n, *shape), kinds) if key in a or default is None else default

        status = array("status", (), "iu") if "status" in a else np.where(array("failed", (), "b"), FAILED, GOOD)
        joint_status = array("joint_status", (joints,), "iu", np.repeat(status[:, None], joints, axis=1))
        for key, codes in (("status", status), ("joint_status", joint_status)):
            if not np.isin(codes, range(len(STATUS_NAMES))).all():
                raise ResultsError(f"{key} holds codes other than 0–{len(STATUS_NAMES) - 1} "
                                   f"({', '.join(STATUS_NAMES)})")
        fps = float(_checked_array(a, "fps", (), "fiu"))
        if not 0 < fps < np.inf:
            raise ResultsError(f"fps must be a positive number, got {fps}")
        result = cls(model, fps, theta.astype(float), array("root_rotation", (3, 3), "fiu").astype(float),
                     array("root_translation", (3,), "fiu").astype(float),
                     np.full((n, len(model.joint_names), 3), np.nan), status.astype(np.uint8),
                     *(array(k, (), "fiu", np.full(n, np.nan)).astype(float) for k in STATS),
                     array("iterations", (), "iu").astype(np.int64),
                     array("link_counts", (links, 4), "iu", np.zeros((n, links, 4), np.int64)).astype(np.int64),
                     array("bar", (), "fiu", np.full(n, np.nan)).astype(float),
                     array("key_point_offset", (joints,), "fiu", np.full((n, joints), np.nan)).astype(float),
                     joint_status.astype(np.uint8),
                     array("unexplained", (), "fiu", np.full(n, np.nan)).astype(float),
                     subject_frame=int(_checked_array(a, "subject_frame", (), "iu")) if "subject_frame" in a else -1)
        if not -1 <= result.subject_frame < n:
            raise ResultsError(f"subject_frame must be a frame of the run (0–{n - 1}) or -1, "
                               f"got {result.subject_frame}")
        if "joints" in a:
            result.joints = array("joints", (joints, 3), "fiu").astype(float)
        else:
            for f in np.flatnonzero(~result.failed):
                result.joints[f] = model.joints(result.theta[f], result.root_rotation[f],
                                                result.root_translation[f], clamp=False)
        return result

    def pose(self, frame: int) -> PoseParameters:
        """The pose of `frame` (NaN when it failed)."""
        return PoseParameters(self.theta[frame], self.root_rotation[frame], self.root_translation[frame])

    def record(self, frame: int, result: FitResult, status: int, iterations: int | None = None,
               bar: float = np.nan) -> None:
        """Store a frame's fit with its status and the `bar` it was judged by (see the
        attribute); a failed frame keeps the fit's statistics (for the report) but no pose."""
        p = result.pose
        self.theta[frame], self.root_rotation[frame], self.root_translation[frame] = \
            p.theta, p.root_rotation, p.root_translation
        self.joints[frame] = self.model.joints(p.theta, p.root_rotation, p.root_translation)
        self.status[frame] = self.joint_status[frame] = status
        self.key_point_offset[frame] = self.unexplained[frame] = np.nan  # measured by the tracker where it can
        for k in STATS:
            getattr(self, k)[frame] = getattr(result, k)
        self.link_counts[frame] = result.link_counts
        self.iterations[frame] = result.iterations if iterations is None else iterations
        self.bar[frame] = bar
        if status == FAILED:
            self.fail(frame)

    def fail(self, frame: int) -> None:
        """Mark a frame failed and forget its pose."""
        self.status[frame] = self.joint_status[frame] = FAILED
        for a in (self.theta, self.root_rotation, self.root_translation, self.joints, self.key_point_offset,
                  self.unexplained):
            a[frame] = np.nan

    def arrays(self) -> dict:
        out = {"root_translation": self.root_translation, "root_rotation": self.root_rotation,
               "theta": self.theta, "dof_names": np.array(self.model.dof_names),
               "joint_names": np.array(self.model.joint_names), "failed": self.failed,
               "status": self.status, "iterations": self.iterations, "link_counts": self.link_counts,
               "bar": self.bar, "joints": self.joints, "fps": self.fps, "subject_frame": self.subject_frame,
               "key_point_offset": self.key_point_offset, "joint_status": self.joint_status,
               "confidence": self.confidence, "unexplained": self.unexplained}
        return out | {k: getattr(self, k) for k in STATS}

    def interpolated(self) -> TrackingResult:
        """A copy whose failed frames between two fitted ones are filled in: joint
        positions, root translation and angles linearly, the root rotation by spherical
        interpolation; they get status ``interpolated``. Failed frames at the ends stay."""
        from scipy.spatial.transform import Rotation, Slerp

        out = replace(self, theta=self.theta.copy(), root_rotation=self.root_rotation.copy(),
                      root_translation=self.root_translation.copy(), joints=self.joints.copy(),
                      status=self.status.copy(), joint_status=self.joint_status.copy())
        known = np.flatnonzero(~self.failed)
        gaps = np.flatnonzero(self.failed)
        gaps = gaps[(gaps > known.min()) & (gaps < known.max())] if len(known) >= 2 else gaps[:0]
        if not len(gaps):
            return out
        for name in ("theta", "root_translation", "joints"):
            a = getattr(out, name)
            flat = a.reshape(len(a), -1)
            for c in range(flat.shape[1]):
                flat[gaps, c] = np.interp(gaps, known, flat[known, c])
        out.root_rotation[gaps] = Slerp(known, Rotation.from_matrix(self.root_rotation[known]))(gaps).as_matrix()
        out.status[gaps] = out.joint_status[gaps] = INTERPOLATED
        return out


def _checked_array(a, key: str, shape: tuple | None, kinds: str) -> np.ndarray:
    """``a[key]`` as an array whose dtype's kind is one of `kinds` (NumPy's letters: f
    float, i and u integers, b bool) and of `shape` (any when ``None``); ResultsError
    naming it otherwise."""
    value = np.asarray(a[key])
    if value.dtype.kind not in kinds:
        raise ResultsError(f"{key} holds {value.dtype} values, not {'/'.join(KINDS[k] for k in kinds)}")
    if shape is not None and value.shape != shape:
        raise ResultsError(f"{key} has shape {value.shape}, not {shape}")
    return value


KINDS = {"f": "floats", "i": "integers", "u": "unsigned integers", "b": "booleans"}


def check_cutoff(cutoff_hz: float, fps: float) -> None:
    """OptionsError unless `cutoff_hz` lies between 0 and half the frame rate `fps`."""
    if not 0 < cutoff_hz < fps / 2:
        raise OptionsError(f"the cut-off must lie between 0 and half the frame rate ({fps / 2:g} Hz), got {cutoff_hz}")


def smooth_joints(joints: np.ndarray, fps: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-lag low-pass filter of joint trajectories, as biomechanics analyses expect: a
    Butterworth filter of `order` run forwards and backwards (so the effective order is
    twice that and nothing is delayed), on each run of consecutive frames without NaN.

    Args:
        joints: (F, J, 3) trajectories; failed frames NaN (runs are filtered separately).
        fps: frame rate; cutoff_hz: the cut-off frequency, below fps / 2.

    Returns:
        (F, J, 3) filtered trajectories; NaN where the input was, and runs too short to
        filter (under 3·(order + 1) frames) left as they were.
    """
    from scipy.signal import butter, filtfilt

    check_cutoff(cutoff_hz, fps)
    joints = np.asarray(joints, float)
    b, a = butter(order, cutoff_hz / (fps / 2))
    out = joints.copy()
    ok = np.isfinite(joints).all(axis=(1, 2))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop - start > 3 * (order + 1):
            out[start:stop] = filtfilt(b, a, joints[start:stop], axis=0)
    return out
