"""The exceptions hullcap raises, so that a caller can tell a bad calibration from a bad
frame or a fit that found nobody.

Every one derives from :class:`HullcapError`, and from ``ValueError`` when the fault lies
in what was given (a file, an array, an option), so ``except ValueError`` keeps working.
Messages name the file, camera, frame or array at fault. Errors of the engine arrive as
the class of their kind (an argument it cannot take as :class:`ArrayError`, a bad mesh or
link model as :class:`ModelError`, an image or voxel grid its image kernels cannot take as
:class:`RasterError`, a bad target or fit input as :class:`FitError`), and
an engine bug — a panic, caught before it can cross into Python — as :class:`EngineError`.
"""

from __future__ import annotations

__all__ = ["HullcapError", "OptionsError", "CalibrationError", "SequenceError", "ViewError", "ModelError",
           "HullError", "RasterError", "FitError", "ArrayError", "TrackingError", "ResultsError", "SessionError",
           "EngineError"]


class HullcapError(Exception):
    """Base of every error hullcap raises on purpose."""


class OptionsError(HullcapError, ValueError):
    """An option out of its range or an unknown name (a motion, a DOF, a method)."""


class CalibrationError(HullcapError, ValueError):
    """A camera calibration: ``cameras.json`` or an import, a field, a rotation, cameras
    that share no volume."""


class SequenceError(HullcapError, ValueError):
    """A sequence folder: ``meta.json``, a frame, video, background or mask of a camera."""


class ViewError(SequenceError):
    """One camera's image or mask of one frame that cannot be used (missing, unreadable,
    truncated, blank, of another size, past the end of its video): the tracker leaves that
    view out of that frame.

    Attributes:
        file: the file at fault (the video, for a video's frame).
        what: what is wrong with it, in words.
        wrong_size: the image has another size than the camera's calibration.
    """

    def __init__(self, file, what: str, wrong_size: bool = False):
        super().__init__(f"{file}: {what}")
        self.file = str(file)
        self.what = what
        self.wrong_size = wrong_size


class ModelError(HullcapError, ValueError):
    """A body or link model, a mesh or a pose given for a model."""


class HullError(HullcapError, ValueError):
    """Silhouettes that carve no visual hull."""


class RasterError(HullcapError, ValueError):
    """An image, mesh or voxel grid the engine's image kernels cannot take: a face naming a
    vertex that does not exist, an image size out of range, a grid whose values do not
    fill its shape."""


class FitError(HullcapError, ValueError):
    """The inputs of a fit or of the subject's model; a hull that shows no person."""


class ArrayError(HullcapError, ValueError):
    """An array or count given to the engine that it cannot take: not an array, of the wrong
    dtype or shape, an index out of range, a count below its minimum. The message names
    the argument."""


class TrackingError(HullcapError, ValueError):
    """A sequence in which no frame shows a body the model can start from."""


class ResultsError(HullcapError, ValueError):
    """A run's results folder or one of its files."""


class SessionError(HullcapError, ValueError):
    """A session folder of takes or its ``session.toml`` (docs/batch.md)."""


class EngineError(HullcapError, RuntimeError):
    """A fault of the engine itself (please report it, with the message)."""
