"""Pictures of a run: the fitted model over each camera's frames (``overlay/<cam>.mp4``)
and the fit statistics over time (``report.png``)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import cv2
import numpy as np

from hullcap._files import publish
from hullcap._progress import progress
from hullcap._render import render_silhouette
from hullcap._results import FAILED, LIMIT_SIDES, RECOVERED, UNCERTAIN
from hullcap.errors import ViewError

__all__ = ["write_overlays", "write_report", "BONES"]

BONES = [("pelvis", "waist"), ("waist", "chest"), ("chest", "neck"), ("neck", "head"),
         ("chest", "l_clavicle"), ("l_clavicle", "l_shoulder"), ("l_shoulder", "l_elbow"), ("l_elbow", "l_wrist"),
         ("chest", "r_clavicle"), ("r_clavicle", "r_shoulder"), ("r_shoulder", "r_elbow"), ("r_elbow", "r_wrist"),
         ("pelvis", "l_hip"), ("l_hip", "l_knee"), ("l_knee", "l_ankle"), ("l_ankle", "l_toe"),
         ("pelvis", "r_hip"), ("r_hip", "r_knee"), ("r_knee", "r_ankle"), ("r_ankle", "r_toe")]
"""Pairs of canonical joints drawn as the skeleton."""

OUTLINE = (40, 220, 255)  # BGR
LEFT, RIGHT, MIDDLE = (60, 200, 60), (60, 60, 230), (230, 160, 40)


def draw_overlay(image, camera, vertices, faces, joints, joint_names, failed: bool = False) -> np.ndarray:
    """`image` (BGR) with the fitted mesh's outline, a light tint over it and the skeleton."""
    out = image.copy()
    if failed:
        cv2.putText(out, "fit failed", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (0, 0, 255), 2, cv2.LINE_AA)
        return out
    seen = render_silhouette(camera, vertices, faces)
    out[seen] = (0.7 * out[seen] + 0.3 * np.array(OUTLINE)).astype(np.uint8)
    contours, _ = cv2.findContours(seen.view(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(out, contours, -1, OUTLINE, 1, cv2.LINE_AA)
    px, z = camera.project(joints)
    index = {n: i for i, n in enumerate(joint_names)}
    for a, b in BONES:
        i, j = index[a], index[b]
        if z[i] > 0 and z[j] > 0:
            colour = LEFT if b.startswith("l_") else RIGHT if b.startswith("r_") else MIDDLE
            p, q = (tuple(int(round(c)) for c in px[k]) for k in (i, j))
            cv2.line(out, p, q, colour, 2, cv2.LINE_AA)
    for k in range(len(joints)):
        if z[k] > 0:
            cv2.circle(out, tuple(int(round(c)) for c in px[k]), 3, (255, 255, 255), -1, cv2.LINE_AA)
    return out


def write_overlays(out, sequence, result, show_progress: bool = True, still: int | None = None) -> list[Path]:
    """``OUT/overlay/<cam>.mp4`` for every camera: the fitted model over its frames.
    Each video is written to a temporary file and moved into place when complete.
    `still`: also save that frame of every camera as ``overlay/<cam>_<frame>.png``."""
    folder = Path(out) / "overlay"
    folder.mkdir(parents=True, exist_ok=True)
    model = result.model
    faces = model.faces
    n = len(result.failed)
    writers, temps = [], []
    for cam in sequence.cameras:
        tmp = tempfile.NamedTemporaryFile(dir=folder, prefix=f".{cam.name}.", suffix=".part.mp4", delete=False)
        tmp.close()
        w = cv2.VideoWriter(tmp.name, cv2.VideoWriter_fourcc(*"mp4v"), result.fps, (cam.width, cam.height))
        if not w.isOpened():
            raise OSError(f"{folder}: cannot write mp4 video for camera {cam.name!r}")
        writers.append(w)
        temps.append(Path(tmp.name))
    done = False
    try:
        for f in progress(range(n), total=n, desc="overlay", enable=show_progress):
            images = [_readable(sequence, f, cam) for cam in sequence.cameras]
            ok = not result.failed[f]
            if ok:
                pose = model.pose(result.theta[f], result.root_rotation[f], result.root_translation[f], clamp=False)
            for cam, img, w in zip(sequence.cameras, images, writers):
                drawn = draw_overlay(img, cam, pose.vertices if ok else None, faces,
                                     pose.joints if ok else None, model.joint_names, failed=not ok)
                w.write(drawn)
                if still == f:
                    cv2.imwrite(str(folder / f"{cam.name}_{f:06d}.png"), drawn)
        done = True
    finally:
        for w in writers:
            w.release()
        if not done:  # interrupted or failed: no half videos left behind
            for tmp in temps:
                tmp.unlink(missing_ok=True)
    paths = []
    for cam, tmp in zip(sequence.cameras, temps):
        final = folder / f"{cam.name}.mp4"
        publish(tmp, final)
        paths.append(final)
    return paths


def _readable(sequence, frame: int, cam) -> np.ndarray:
    """The camera's image of `frame`, or a grey one saying it could not be read (the run's
    problems.json says why)."""
    try:
        return sequence.image(frame, cam.name)
    except ViewError:
        img = np.full((cam.height, cam.width, 3), 96, np.uint8)
        cv2.putText(img, "image unreadable", (10, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 2, cv2.LINE_AA)
        return img


def write_report(path, result, truth_joints=None) -> None:
    """``report.png``, the fit of every frame over time (failed frames shaded red,
    recovered ones orange): how much of the hull it explains both ways (its model points
    with a hull partner, the hull samples with a model partner, their mean, the quality)
    against the bar the frame had to reach to stand without a search; the mean distance of
    its pairs both ways; the frames where a joint angle was held at one of the model's
    limits (:meth:`~hullcap._results.TrackingResult.at_limits`, the most held first);
    each joint's confidence (:attr:`~hullcap._results.TrackingResult.confidence`; frames
    marked uncertain shaded purple); the frame the subject's model was built from (a
    dotted line); and, with
    `truth_joints` (F × J × 3), the joint error per body region."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    t = np.arange(len(result.status)) / result.fps
    at_limits = result.at_limits()
    held = result.limits_held(at_limits)[:REPORT_LIMIT_ROWS]
    heights = ([2.6, 2.6, 0.6 + 0.22 * max(len(held), 2), 0.6 + 0.12 * len(result.model.joint_names)]
               + ([2.6] if truth_joints is not None else []))
    fig, ax = plt.subplots(len(heights), 1, figsize=(9, sum(heights)), sharex=True,
                           gridspec_kw={"height_ratios": heights})
    ax[0].plot(t, result.inlier_fraction * 100, lw=0.9, color="tab:green", label="model → hull (inliers)")
    ax[0].plot(t, result.coverage * 100, lw=0.9, color="tab:blue", label="hull → model (coverage)")
    ax[0].plot(t, result.quality * 100, lw=1.6, color="black", label="quality (their mean)")
    if np.isfinite(result.bar).any():  # runs before the bar was kept have none
        ax[0].plot(t, result.bar * 100, lw=1.0, ls="--", color="tab:red", label="bar without a search")
    ax[0].set(ylabel="explained (%)")
    ax[0].legend(fontsize=8, ncol=2, loc="lower left")
    ax[1].plot(t, result.mean_residual * 1000, lw=1.2, color="tab:green", label="model → hull")
    ax[1].plot(t, result.mean_reverse_residual * 1000, lw=1.2, color="tab:blue", label="hull → model")
    ax[1].set(ylabel="mean pair distance (mm)")
    ax[1].legend(fontsize=8, ncol=2, loc="upper left")
    _plot_limits_held(ax[2], t, result.model.dof_names, at_limits, held)
    _plot_confidence(ax[3], t, result)
    if truth_joints is not None:
        names = result.model.joint_names
        err = np.linalg.norm(result.joints - truth_joints[: len(t)], axis=2) * 1000
        groups = {"torso and head": ("pelvis", "waist", "chest", "neck", "head"),
                  "arms": tuple(n for n in names if any(k in n for k in ("clavicle", "shoulder", "elbow", "wrist"))),
                  "legs": tuple(n for n in names if any(k in n for k in ("hip", "knee", "ankle", "toe")))}
        for label, members in groups.items():
            idx = [names.index(m) for m in members]
            ax[4].plot(t, err[:, idx].mean(1), lw=1.2, label=label)
        ax[4].set(ylabel="joint error (mm)")
        ax[4].legend(fontsize=8, ncol=3)
    counts = {status: int((result.status == status).sum()) for status in (FAILED, RECOVERED, UNCERTAIN)}
    fig.suptitle("How well each frame's fit explains its visual hull")
    subject = (f"; the subject's model from frame {result.subject_frame} (dotted)"
               if result.subject_frame >= 0 else "")
    ax[0].set_title(f"{len(t)} frames: {counts[FAILED]} failed (shaded red), {counts[RECOVERED]} recovered by a "
                    f"search (orange), {counts[UNCERTAIN]} uncertain (purple){subject}", fontsize=9)
    for a in ax:
        a.grid(alpha=0.3)
        if result.subject_frame >= 0:
            a.axvline(t[result.subject_frame], color="black", ls=":", lw=1.0)
        for status, colour in ((FAILED, "red"), (RECOVERED, "orange"), (UNCERTAIN, "purple")):
            for f in np.flatnonzero(result.status == status):
                a.axvspan(t[f] - 0.5 / result.fps, t[f] + 0.5 / result.fps, color=colour, alpha=0.25, lw=0)
    ax[-1].set(xlabel="time (s)")
    fig.tight_layout()
    from hullcap._files import atomic_write

    atomic_write(Path(path), lambda p: fig.savefig(p, dpi=100))
    plt.close(fig)


REPORT_LIMIT_ROWS = 12
"""The most joint angles held at a limit that ``report.png`` shows, the most held first."""


def _plot_confidence(ax, t, result) -> None:
    """Each joint's confidence over time, one row per joint, from red (0) to green (1),
    blank where it is not judged."""
    confidence = result.confidence
    shown = np.ma.masked_invalid(confidence.T)
    step = 1 / result.fps
    ax.imshow(shown, aspect="auto", interpolation="nearest", cmap="RdYlGn", vmin=0.0, vmax=1.0,
              extent=(t[0] - step / 2, t[-1] + step / 2, len(result.model.joint_names) - 0.5, -0.5))
    ax.set_yticks(range(len(result.model.joint_names)), result.model.joint_names, fontsize=6)
    if np.isfinite(confidence).any():
        title = "each joint's confidence: its distance from the person's key points (red 0, green 1)"
    else:
        title = "joints not judged: no key points (the learned segmenter did not run)"
        if np.isfinite(result.unexplained).any():
            title += "; frames judged against the background test's masks"
    ax.set_title(title, fontsize=9)


def _plot_limits_held(ax, t, dof_names, at_limits, held) -> None:
    """One row per angle of `held` (:meth:`~hullcap._results.TrackingResult.limits_held`)
    with a mark at each frame where `at_limits` (its :meth:`at_limits`) has it at that limit."""

    dofs = list(dof_names)
    for row, (name, side, _) in enumerate(held):
        frames = np.flatnonzero(at_limits[:, dofs.index(name)] == LIMIT_SIDES[side])
        ax.plot(t[frames], np.full(len(frames), row), "|", ms=7, color="tab:purple")
    ax.set_yticks(range(len(held)), [f"{name} ({side})" for name, side, _ in held], fontsize=7)
    ax.set_ylim(len(held) - 0.5 if held else 1, -0.5 if held else -1)
    ax.set_title("joint angles held at a limit of the model: there a bound, not a measurement", fontsize=9)
    if not held:
        ax.set_yticks([])
        ax.text(0.5, 0.5, "no joint angle held at a limit of the model", transform=ax.transAxes,
                ha="center", va="center", fontsize=8)
