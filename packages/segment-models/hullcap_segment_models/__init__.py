"""MediaPipe 0.10.21's pose models as files (README.md)."""

from pathlib import Path

__all__ = ["DETECTOR", "LANDMARKS", "SOURCE"]

_HERE = Path(__file__).resolve().parent
DETECTOR = _HERE / "pose_detection.tflite"
"""The pose detector: a 224 × 224 RGB image in [-1, 1] → 2254 anchor boxes, each with four
key points, and their scores."""
LANDMARKS = _HERE / "pose_landmark_full.tflite"
"""The full pose landmark model: a 256 × 256 RGB crop in [0, 1] → 39 landmarks, the
person's presence, and the crop's segmentation (logits)."""
SOURCE = "MediaPipe 0.10.21 (Apache 2.0)"
