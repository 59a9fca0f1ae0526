"""Reading documents and NumPy archives with errors that name the file, and atomic
writes: a reader sees the old file or the whole new one, never a part."""

from __future__ import annotations

import json
import os
import tempfile
import tomllib
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

NPZ_ERRORS = (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error)
"""What reading a damaged ``.npz`` raises: not a zip, a cut member, bad compressed data,
a missing array, a header NumPy does not accept."""


def _umask() -> int:
    """The process's umask: from /proc where it is (reading it elsewhere means setting it
    for a moment)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def publish(tmp, path) -> None:
    """Move the finished temporary file `tmp` to `path`, with the permissions a file
    created there would get (0666 less the umask: temporary files are private, 0600)."""
    os.chmod(tmp, 0o666 & ~_umask())
    os.replace(tmp, path)


def atomic_write(path, data: bytes | Callable[[Path], None]) -> None:
    """Write `data` (bytes, or a function that writes a given temporary path) to `path`
    through a temporary file in the same folder, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part" + path.suffix, dir=path.parent)
    try:
        if callable(data):
            os.close(fd)
            data(Path(tmp))
        else:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
        publish(tmp, path)
    except OSError as e:
        Path(tmp).unlink(missing_ok=True)
        if e.filename is None:  # a failed write names no file ("No space left on device"): name it
            raise OSError(e.errno, e.strerror, str(path)) from e
        raise
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def read_document(path, error: type[Exception] = ValueError) -> dict:
    """A JSON (``*.json``) or TOML (``*.toml``) file parsed; `error` (one of
    :mod:`hullcap.errors`) names the file when it cannot be read or parsed."""
    path = Path(path)
    toml = path.suffix.lower() == ".toml"
    try:
        text = path.read_text()
        doc = tomllib.loads(text) if toml else json.loads(text)
    except OSError as e:
        raise error(f"{path}: cannot read ({e.strerror})") from e
    except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise error(f"{path}: not valid {'TOML' if toml else 'JSON'} ({e})") from e
    if not isinstance(doc, dict):
        raise error(f"{path}: expected a {'table' if toml else 'JSON object'} at the top, got {type(doc).__name__}")
    return doc


def read_npz(path, error: type[Exception] = ValueError, what: str = "readable NumPy archive") -> dict:
    """Every array of the ``.npz`` file `path`; `error` (one of :mod:`hullcap.errors`)
    names the file and says it is not a `what` when it cannot be read."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except NPZ_ERRORS as e:
        raise error(f"{path}: not a {what} ({e})") from None
