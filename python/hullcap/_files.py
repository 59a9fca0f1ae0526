"""Reading documents with errors that name the file, and atomic writes: a reader sees
the old file or the whole new one, never a part."""

from __future__ import annotations

import json
import os
import tempfile
import tomllib
from collections.abc import Callable
from pathlib import Path


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
        os.replace(tmp, path)
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
        return tomllib.loads(text) if toml else json.loads(text)
    except OSError as e:
        raise error(f"{path}: cannot read ({e.strerror})") from e
    except (json.JSONDecodeError, tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise error(f"{path}: not valid {'TOML' if toml else 'JSON'} ({e})") from e
