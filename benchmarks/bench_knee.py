"""The knee search of the subject's model on the development set: how far its move lies
from the truth's, and how much one frame more or less changes it (docs/notebooks/accuracy.md, "The
knee search decides by the mean gain alone").

For each sequence and silhouette source the tracker builds the subject's model as
`hullcap track` does, up to the knee search (`hullcap._subject.search_centres`), whose
frames, poses and model are taken there and the run stopped. Each frame is refitted at
every knee move of the search's grid, and the move `best_move` makes is printed with all
frames and with each frame left out in turn, beside the truth's move: the one that gives
the model the truth's thigh length.

    .venv/bin/python benchmarks/bench_knee.py [--only d01_bend ...] [--silhouettes colour exact]

About 1–2 minutes per run on 2 cores (the first seconds tracked, then the refits).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import devset
import hullcap._subject_builder as builder
from hullcap import Tracker, TrackerOptions
from hullcap._sequence import Sequence
from hullcap._subject import best_move, centre_profile


class _Searched(Exception):
    """Carries the knee search's inputs out of the tracker."""

    def __init__(self, model, joint, axis, targets, poses, options):
        super().__init__("knee search reached")
        self.model, self.joint, self.axis, self.targets, self.poses, self.options = \
            model, joint, axis, targets, poses, options


def _intercept(model, joint, axis, targets, poses, options=None):
    raise _Searched(model, joint, axis, targets, poses, options)


def search_inputs(sequence: Path, exact: bool) -> _Searched | None:
    """The knee search's inputs of one run, or None if the run never searches."""
    tracker = Tracker(Sequence(sequence), options=TrackerOptions(ignore_silhouettes=not exact))
    real, builder.search_centres = builder.search_centres, _intercept
    try:
        tracker.run(devset.CACHE / "knee" / f"{sequence.name}-{'exact' if exact else 'colour'}",
                    resume=False, show_progress=False, frames=None)
    except _Searched as found:
        return found
    finally:
        builder.search_centres = real
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--devset", help="the development set's folder (default $HULLCAP_DEVSET or ../shared/devset)")
    ap.add_argument("--only", nargs="+", help="these sequences only")
    ap.add_argument("--silhouettes", nargs="+", choices=["colour", "exact"], default=["colour", "exact"])
    args = ap.parse_args()
    devset_dir = devset.find(args.devset)
    if devset_dir is None:
        ap.error("the development set is not here: pass --devset or set HULLCAP_DEVSET")
    print("| run | frames | truth's move (cm) | move (cm) | one frame left out (cm) | their spread (cm) |")
    print("|---|---|---|---|---|---|")
    for name in args.only or devset.names(devset_dir):
        sequence = devset.render(devset_dir, name)
        truth = devset.Truth.load(devset_dir, sequence).limb_lengths()
        for mode in args.silhouettes:
            found = search_inputs(sequence, mode == "exact")
            if found is None or not found.targets:
                why = "no knee search (the model was not refined)" if found is None else "no frame bends enough"
                print(f"| {name} {mode} | 0 | | | {why} | |", flush=True)
                continue
            # A knee moved up by m (body z) shortens the thigh by m: the truth's move is
            # the model's thigh length less the truth's.
            wanted = devset.model_limb_lengths(found.model)["thigh"] - truth["thigh"]
            moves, per_frame = centre_profile(found.model, found.joint, found.axis, found.targets, found.poses,
                                              found.options)
            move = best_move(moves, per_frame, found.options)
            left_out = [best_move(moves, np.delete(per_frame, k, axis=1), found.options)
                        for k in range(per_frame.shape[1])]
            print(f"| {name} {mode} | {per_frame.shape[1]} | {100 * wanted:+.1f} | {100 * move:+.1f} | "
                  + ", ".join(f"{100 * m:+.1f}" for m in left_out) + f" | {100 * np.std(left_out):.2f} |", flush=True)


if __name__ == "__main__":
    main()
