"""A session: a folder of takes, whose they are, and each take's options (docs/batch.md).

Without a ``session.toml`` every sequence folder directly under the session (one with a
``cameras.json``) is a take, and each take builds its own subject model. With one::

    [defaults]            # options of every take (those of hullcap track)
    overlays = false

    [subjects]            # each person's calibration take: their model is built there
    anna = "anna_static"

    [takes]               # the takes to track (default: every sequence folder)
    anna_walk = "anna"                          # whose take it is
    ben_jump = { voxel_size = 0.008 }              # no subject: builds its own model
    anna_run = { subject = "anna", frames = 300 }

A take of a listed person is tracked with the model of that person's calibration take
(``hullcap track --model``); the calibration takes are tracked too, listed or not, and
first.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hullcap._files import read_document
from hullcap._take import TakeOptions
from hullcap.errors import OptionsError, SessionError

__all__ = ["Take", "load_session", "SESSION_FILE"]

SESSION_FILE = "session.toml"


@dataclass(frozen=True)
class Take:
    """One take of a session.

    Attributes:
        name: its folder's name under the session.
        path: its sequence folder.
        subject: the person in it (``None``: not named; the take builds its own model).
        calibration: the take whose model it is tracked with (``None``: it builds its own:
            a take without a subject, or a subject's calibration take).
        options: how it is tracked.
    """

    name: str
    path: Path
    subject: str | None
    calibration: str | None
    options: TakeOptions


def load_session(folder) -> list[Take]:
    """The takes of session `folder`, every calibration take before the takes that use its
    model; a :class:`~hullcap.errors.SessionError` names what is wrong."""
    folder = Path(folder)
    if not folder.is_dir():
        raise SessionError(f"{folder}: no such session folder")
    config = folder / SESSION_FILE
    if not config.is_file():
        names = _sequence_folders(folder)
        if not names:
            raise SessionError(f"{folder}: no take in it (a sequence folder with cameras.json) and no {SESSION_FILE}")
        return [Take(name, folder / name, None, None, TakeOptions()) for name in names]
    doc = read_document(config, SessionError)
    unknown = set(doc) - {"defaults", "subjects", "takes"}
    if unknown:
        raise SessionError(f"{config}: unknown table {sorted(unknown)[0]!r}; tables: defaults, subjects, takes")
    defaults = _options(_table(doc, "defaults", config), f"{config} [defaults]", TakeOptions())
    subjects = _table(doc, "subjects", config)
    for person, take in subjects.items():
        if not isinstance(take, str):
            raise SessionError(f"{config} [subjects]: {person} must name a take folder, got {take!r}")
        _check_take_folder(folder, take, f"{config} [subjects] {person}")
    listed = _table(doc, "takes", config) if "takes" in doc else {name: {} for name in _sequence_folders(folder)}
    entries = {take: {"subject": person} for person, take in subjects.items()}
    for name, entry in listed.items():
        where = f"{config} [takes] {name}"
        if isinstance(entry, str):
            entry = {"subject": entry}
        elif not isinstance(entry, dict):
            raise SessionError(f"{where}: a subject's name or a table of options, got {entry!r}")
        entry = dict(entry)
        calibrating = entries.get(name, {}).get("subject")
        if calibrating is not None:
            if entry.setdefault("subject", calibrating) != calibrating:
                raise SessionError(f"{where}: it is {calibrating}'s calibration take ([subjects]), "
                                   f"not {entry['subject']}'s")
        entries[name] = entry
    takes = []
    for name, entry in entries.items():
        where = f"{config} [takes] {name}"
        subject = entry.pop("subject", None)
        if subject is not None and subject not in subjects:
            raise SessionError(f"{where}: subject {subject!r} has no calibration take in [subjects] "
                               f"(known: {', '.join(subjects) or 'none'})")
        _check_take_folder(folder, name, where)
        calibration = None if subject is None or subjects[subject] == name else subjects[subject]
        takes.append(Take(name, folder / name, subject, calibration, _options(entry, where, defaults)))
    if not takes:
        raise SessionError(f"{config}: no take to track")
    return sorted(takes, key=lambda t: t.calibration is not None)


def _sequence_folders(folder: Path) -> list[str]:
    """The names of the folders directly in `folder` that hold a ``cameras.json``, sorted."""
    return sorted(p.name for p in folder.iterdir() if (p / "cameras.json").is_file())


def _table(doc: dict, key: str, config: Path) -> dict:
    value = doc.get(key, {})
    if not isinstance(value, dict):
        raise SessionError(f"{config}: [{key}] must be a table, got {value!r}")
    return value


def _options(table: dict, where: str, base: TakeOptions) -> TakeOptions:
    try:
        return TakeOptions.from_table(table, where, base)
    except OptionsError as e:
        raise SessionError(str(e)) from None


def _check_take_folder(session: Path, name: str, where: str) -> None:
    path = session / name
    if Path(name).name != name or name in ("", ".", ".."):
        raise SessionError(f"{where}: {name!r} must be the name of a folder directly in the session")
    if not (path / "cameras.json").is_file():
        raise SessionError(f"{where}: {path} is not a sequence folder (no cameras.json)")
