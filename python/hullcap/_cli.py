"""The ``hullcap`` command line: a thin layer over the Python API."""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from hullcap.errors import HullcapError, OptionsError

__all__ = ["main"]


def _track(args) -> int:
    from hullcap._take import TakeOptions, track_take

    track_take(args.sequence, args.out, TakeOptions.from_arguments(args), model=args.model, resume=not args.restart,
               say=print, warn=lambda line: print(f"hullcap: warning: {line}", file=sys.stderr))
    return 0


def _batch(args) -> int:
    from hullcap._batch import default_runner, run_batch

    runner = default_runner(args.sequential, args.address, args.cpus_per_take)
    rows = run_batch(args.session, args.out, runner, restart=args.restart)
    return 0 if all(row.finished for row in rows) else 1


def _synth(args) -> int:
    from hullcap._synth import synthesize

    out = synthesize(args.out, args.motion, args.cameras, args.subject, fps=args.fps, noise=args.noise,
                     seed=args.seed, silhouettes=args.silhouettes, frames=args.frames)
    size = sum(f.stat().st_size for f in out.rglob("*") if f.is_file())
    print(f"{out}: rendered ({size / 1e6:.0f} MB); ground truth in {out / 'truth'}")
    return 0


def _demo(args) -> int:
    from hullcap._evaluate import accuracy, true_joints
    from hullcap._sequence import Sequence
    from hullcap._synth import synthesize
    from hullcap._tracking import Tracker, TrackerOptions
    from hullcap.export import write_report

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.out) if args.out else Path(tmp)
        print(f"hullcap demo: rendering the '{args.motion}' motion of a '{args.subject}' subject "
              f"seen by {args.cameras} cameras (640×480)")
        t0 = time.perf_counter()
        seq_path = synthesize(root / "sequence", args.motion, args.cameras, args.subject, seed=args.seed)
        render_s = time.perf_counter() - t0
        seq = Sequence(seq_path)
        print("tracking: background subtraction → visual hull → subject model from the first frames → "
              "hierarchical robust ICP per frame")
        tracker = Tracker(seq, options=TrackerOptions(ignore_silhouettes=True))
        t0 = time.perf_counter()
        result = tracker.run(root / "result", resume=False)
        track_s = time.perf_counter() - t0
        acc = accuracy(result, seq_path)
        # The report again, with the joint error per body region against the truth.
        write_report(root / "result" / "report.png", result, true_joints(result, seq_path))
        n = len(seq)
        print("\n" + acc.table())
        print(f"\nspeed on this machine ({n} frames, {args.cameras} cameras):")
        print(f"  rendering the sequence       {n / render_s:6.1f} frames/s")
        for stage in ("silhouettes", "read ahead", "hull", "fit"):
            s = result.seconds.get(stage, 0.0)
            label = f"{stage} (2nd thread)" if stage == "read ahead" else stage
            print(f"  {label:<28} {n / s if s else float('inf'):6.1f} frames/s  ({1000 * s / n:.0f} ms per frame)")
        print(f"  subject model (built, refined) {result.seconds.get('subject', 0):5.1f} s")
        print(f"  whole pipeline               {n / track_s:6.1f} frames/s")
        if args.out:
            print(f"\nsequence in {seq_path}, results in {root / 'result'}")
    return 0


def _export(args) -> int:
    from hullcap._results import smooth_joints
    from hullcap.export import load_result, write_joints_csv
    from hullcap.export import angle_table, write_angles_csv, write_bvh, write_c3d, write_glb, write_mot, write_trc

    result = load_result(args.out)
    if args.drop_uncertain and args.format not in ("trc", "c3d", "csv"):
        raise OptionsError(f"--drop-uncertain applies to trc, c3d and csv, not {args.format}")
    if args.interpolate:
        result = result.interpolated()
    if args.smooth:
        result.joints = smooth_joints(result.joints, result.fps, args.smooth)
    names = {"bvh": "motion.bvh", "glb": "model.glb", "c3d": "joints.c3d", "csv": "joints.csv", "trc": "joints.trc",
             "mot": "angles.mot", "angles": "angles.csv"}
    target = Path(args.to) if args.to else Path(args.out) / names[args.format]
    motion = (result.model, result.root_translation, result.root_rotation, result.theta, result.fps)
    convention = {k: v for k, v in (("up", args.up), ("units", args.units)) if v}
    if convention and args.format not in ("bvh", "trc"):
        raise OptionsError(f"--up and --units apply to bvh and trc, not {args.format}")
    if args.format == "bvh":
        write_bvh(target, *motion, **convention)
    elif args.format == "trc":
        write_trc(target, result.model.joint_names, result.joints_kept(args.drop_uncertain), result.fps, **convention)
    elif args.format == "glb":
        write_glb(target, *motion)
    elif args.format == "c3d":
        write_c3d(target, result.model.joint_names, result.joints_kept(args.drop_uncertain), result.fps,
                  residuals=result.key_point_offset)
    elif args.format in ("mot", "angles"):
        columns, values = angle_table(result.model.dof_names, result.theta, result.root_translation,
                                      result.root_rotation, result.fps)
        if args.smooth:
            values[:, 1:] = smooth_joints(values[:, 1:, None], result.fps, args.smooth)[..., 0]
        (write_mot if args.format == "mot" else write_angles_csv)(target, columns, values)
    else:
        write_joints_csv(target, result, drop_uncertain=args.drop_uncertain)
    print(f"{target}: written from {Path(args.out) / 'pose.npz'}")
    return 0


def _compare(args) -> int:
    from hullcap._compare import compare_run

    comparison = compare_run(args.out, args.reference, names=args.names, shift=args.shift, up=args.up,
                             align=args.align)
    print(f"{args.out} against {args.reference}:")
    print(comparison.table())
    if args.json:
        from hullcap._files import atomic_write

        atomic_write(Path(args.json), json.dumps(comparison.to_dict(), indent=1).encode())
        print(f"{args.json}: written")
    if args.plot:
        comparison.plot(args.plot, f"{Path(args.out).name} against {Path(args.reference).name}")
        print(f"{args.plot}: written")
    return 0


def _calib_import(args) -> int:
    from hullcap._cameras import parse_size
    from hullcap._rig import describe, image_sizes, import_calibration, match_to_images

    size, sizes = None, None
    if args.images:
        size = sizes = image_sizes(args.images)
    if args.size:
        size = parse_size(args.size, "--size")
    cameras = import_calibration(args.kind, args.sources, image_size=size, up=args.up)
    if sizes is not None:
        cameras, notes = match_to_images(cameras, sizes, args.rename)
        for note in notes:
            print(note)
    elif args.rename:
        raise OptionsError("--rename matches the calibration's cameras to images: give --images too")
    cameras.save(args.out)
    print(describe(cameras))
    print(f"\n{args.out}: {len(cameras)} cameras written")
    return 0


def _calib_show(args) -> int:
    from hullcap._cameras import Cameras
    from hullcap._rig import describe, draw_top_view

    cameras = Cameras.load(args.cameras)
    print(describe(cameras))
    picture = Path(args.picture) if args.picture else Path(args.cameras).with_suffix(".png")
    draw_top_view(picture, cameras)
    print(f"top view of the rig: {picture}")
    return 0


def _calib_check(args) -> int:
    from hullcap._agreement import describe_agreement, draw_agreement, view_agreement
    from hullcap._sequence import Sequence
    from hullcap._tracking import Tracker, TrackerOptions
    from hullcap.errors import OptionsError, ViewError

    seq = Sequence(args.sequence, cameras=args.cameras, leave_out=args.leave_out)
    if not 0 <= args.frame < len(seq):
        raise OptionsError(f"--frame {args.frame}: {args.sequence} has frames 0 to {len(seq) - 1}")
    tracker = Tracker(seq, options=TrackerOptions(ignore_silhouettes=args.ignore_silhouettes))
    masks = tracker.masks(args.frame)
    agreements = view_agreement(masks, seq.cameras, args.voxel_size)
    print(describe_agreement(agreements, args.frame))
    images = []
    for cam in seq.cameras:
        try:
            images.append(seq.image(args.frame, cam.name))
        except ViewError:
            images.append(None)  # masks without frames, or a broken image: the silhouette alone
    picture = Path(args.picture) if args.picture else Path(args.sequence) / "cameras_check.png"
    draw_agreement(picture, images, masks, seq.cameras, agreements, args.voxel_size)
    print(f"every view, green where the others agree and red where they carve its silhouette away: {picture}")
    return 0


def _renames(text: str) -> dict[str, str]:
    """``--rename cam_01=left,cam_02=right`` → {'cam_01': 'left', 'cam_02': 'right'}."""
    pairs = [p.split("=") for p in text.split(",")]
    if not all(len(p) == 2 and p[0].strip() and p[1].strip() for p in pairs):
        raise argparse.ArgumentTypeError(f"OLD=NEW pairs separated by commas, got {text!r}")
    return {old.strip(): new.strip() for old, new in pairs}


def _shift(text: str):
    """``--shift``: seconds, or 'auto'."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number of seconds or 'auto', got {text!r}") from None


class _Parser(argparse.ArgumentParser):
    """The command's parsers: an option is never taken from a prefix of its name
    (``--frame 10`` is not ``--frames 10``), and a subcommand's unknown arguments are
    refused with that subcommand's usage, not the top level's."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def parse_known_args(self, args=None, namespace=None):
        namespace, extras = super().parse_known_args(args, namespace)
        is_subcommand = " " in self.prog
        has_subcommands = any(isinstance(a, argparse._SubParsersAction) for a in self._actions)
        if extras and is_subcommand and not has_subcommands:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


def build_parser() -> argparse.ArgumentParser:
    from hullcap import __version__
    from hullcap._motions import MOTIONS
    from hullcap._options import add_flags
    from hullcap._synth import SUBJECTS
    from hullcap._take import TakeOptions
    from hullcap._tracking_options import TrackerOptions

    ap = _Parser(prog="hullcap",
                                 description="Markerless motion capture from calibrated multi-view video.")
    ap.add_argument("--version", action="version", version=f"hullcap {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)

    t = sub.add_parser("track", help="track a sequence folder", description=(
        "Track the person in a sequence folder (cameras.json, meta.json, frames/ or videos/, "
        "background/ or silhouettes/): writes joints.csv, pose.npz, model/, motion.bvh, model.glb, "
        "report.png and overlay/<cam>.mp4 to OUT. An interrupted run resumes where it stopped."))
    t.add_argument("sequence", help="the sequence folder")
    t.add_argument("--out", required=True, help="the results folder")
    t.add_argument("--model", help="a body model folder from an earlier run of the same subject (skips building one)")
    t.add_argument("--restart", action="store_true", help="start over instead of resuming")
    add_flags(t, TrackerOptions)
    add_flags(t, TakeOptions)
    t.set_defaults(run=_track)

    b = sub.add_parser("batch", help="track every take of a session folder, on Ray", description=(
        "Track every take of a session folder (its sequence folders, or those its session.toml lists, with "
        "each person's calibration take and per-take options: docs/batch.md) into OUT/<take>/, as hullcap "
        "track does, reusing one subject model per person. Runs on Ray when it is installed (hullcap[ray]): "
        "on this machine's cores, or on a cluster with --address. A take that fails is tried once more; "
        "a re-run skips finished takes and resumes interrupted ones. Ends with a summary table "
        "(OUT/summary.csv); the exit status is 1 when a take failed."))
    b.add_argument("session", help="the session folder")
    b.add_argument("--out", required=True, help="the results folder: one folder per take")
    b.add_argument("--address", help="the Ray cluster to run on, e.g. ray://head:10001 or auto (default: start "
                                      "Ray on this machine)")
    b.add_argument("--cpus-per-take", type=float, default=1.0, metavar="N",
                   help="CPUs Ray reserves for each take (default 1: as many takes at once as cores)")
    b.add_argument("--sequential", action="store_true", help="one take after another in this process, without Ray")
    b.add_argument("--restart", action="store_true", help="track every take again, finished or not")
    b.set_defaults(run=_batch)

    s = sub.add_parser("synth", help="render a synthetic sequence with ground truth", description=(
        "Render the template body with other proportions through a scripted motion into a "
        "sequence folder, with the true joints, pose and vertices in truth/. Lossless PNG frames take "
        "about 0.5 MB a camera and frame at 640x480: the demo motion with 8 cameras writes about 0.35 GB, "
        "--motion all about 1.2 GB (--frames N renders fewer)."))
    s.add_argument("out", help="the sequence folder to write")
    s.add_argument("--motion", choices=sorted(MOTIONS), default="demo", help="the scripted motion (default demo)")
    s.add_argument("--cameras", type=int, default=8, help="cameras on a ring (default 8)")
    s.add_argument("--subject", choices=sorted(SUBJECTS), default="tall", help="body proportions (default tall)")
    s.add_argument("--fps", type=float, default=30.0, help="frame rate (default 30)")
    s.add_argument("--noise", type=float, default=2.0, help="sensor noise, grey levels (default 2)")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--frames", type=int, help="render only the first N frames")
    s.add_argument("--silhouettes", action="store_true", help="also write the exact silhouettes as input")
    s.set_defaults(run=_synth)

    d = sub.add_parser("demo", help="render, track and score a synthetic sequence", description=(
        "Render a synthetic 8-camera sequence, track it from its colour frames (background "
        "subtraction, visual hull, subject model, ICP) and print the joint errors against the "
        "truth and the speed of each stage."))
    d.add_argument("--motion", choices=sorted(MOTIONS), default="demo")
    d.add_argument("--subject", choices=sorted(SUBJECTS), default="tall")
    d.add_argument("--cameras", type=int, default=8)
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--out", help="keep the sequence and results here (default: a temporary folder)")
    d.set_defaults(run=_demo)

    c = sub.add_parser("calib", help="import a calibration, show a rig, or check it on a sequence", description=(
        "Import other tools' calibrations into cameras.json, or describe one: each camera's centre, "
        "viewing direction and size, the capture volume, and a top-view picture of the rig; or check "
        "on a sequence's frame that the cameras agree on the person."))
    csub = c.add_subparsers(dest="calib_command", required=True)
    ci = csub.add_parser("import", help="write cameras.json from EasyMocap, Pose2Sim or OpenCV files",
                         description="Write cameras.json from another tool's calibration files.")
    ci.add_argument("--from", dest="kind", choices=["easymocap", "pose2sim", "opencv"], required=True,
                    help="easymocap: intri.yml extri.yml; pose2sim: Calib*.toml; opencv: one FileStorage "
                         "file per camera (camera_matrix, distortion_coefficients, R or rvec, T or tvec)")
    ci.add_argument("sources", nargs="+", help="the calibration files")
    ci.add_argument("--out", required=True, help="the cameras.json to write")
    ci.add_argument("--size", metavar="WxH", help="image size of every camera, for files that do not store it")
    ci.add_argument("--images", metavar="FOLDER",
                    help="the sequence folder whose FOLDER/frames/<cam>/ or FOLDER/videos/<cam>.* the cameras film: "
                         "each camera is named as its images are (cam_01 and cam01 alike) and takes their size (a "
                         "video a little smaller or larger than calibrated is taken as the calibrated frame resized, "
                         "its intrinsics scaled, and said so)")
    ci.add_argument("--rename", type=_renames, metavar="OLD=NEW,...",
                    help="with --images: the images' name of each camera of the calibration that is named otherwise")
    ci.add_argument("--up", choices=["z", "y"], default="z", help="the up axis of the files' world (default z)")
    ci.set_defaults(run=_calib_import)
    cs = csub.add_parser("show", help="describe a cameras.json and draw the rig from above",
                         description="Print each camera and the capture volume; write a top view of the rig.")
    cs.add_argument("cameras", help="a cameras.json")
    cs.add_argument("--picture", help="the top view to write (default: next to the file, .png)")
    cs.set_defaults(run=_calib_show)
    ck = csub.add_parser("check", help="check that a sequence's cameras agree on the person",
                         description="Carve the visual hull of one frame from every view and from every view but "
                                     "one: print how much of each camera's silhouette the others agree with and "
                                     "which camera disagrees (a wrong calibration, or a wrong background), and "
                                     "write a picture of every view showing where.")
    ck.add_argument("sequence", help="the sequence folder")
    ck.add_argument("--frame", type=int, default=0, help="the frame to check (default 0, the calibration pose)")
    ck.add_argument("--picture", help="the picture to write (default: SEQUENCE/cameras_check.png)")
    add_flags(ck, TrackerOptions, ["voxel_size", "ignore_silhouettes"])
    add_flags(ck, TakeOptions, ["cameras", "leave_out"])
    ck.set_defaults(run=_calib_check)

    e = sub.add_parser("export", help="re-export a finished run without tracking again", description=(
        "Write a finished run's motion (its pose.npz and model/) in another format."))
    e.add_argument("out", help="the results folder of a `hullcap track` run")
    e.add_argument("--format", choices=["bvh", "glb", "c3d", "trc", "csv", "mot", "angles"], required=True,
                   help="bvh: motion.bvh (Blender, MotionBuilder); glb: model.glb (skinned mesh + motion); "
                        "c3d: joints.c3d (biomechanics tools; needs ezc3d); trc: joints.trc (OpenSim markers); "
                        "csv: joints.csv; mot: angles.mot (joint angles in degrees, OpenSim's motion file); "
                        "angles: angles.csv (the same as CSV)")
    e.add_argument("--up", choices=["y", "z"],
                   help="bvh, trc: the up axis (default y, what Blender's importer and OpenSim assume; "
                        "z: our world as in joints.csv)")
    e.add_argument("--units", choices=["m", "cm", "mm"],
                   help="bvh: m (default) or cm; trc: mm (default) or m")
    e.add_argument("--to", help="the file to write (default: the standard name inside OUT)")
    e.add_argument("--drop-uncertain", action="store_true",
                   help="trc, c3d, csv: write the joints marked uncertain as missing (gaps), as failed frames are")
    add_flags(e, TakeOptions, ["interpolate", "smooth"])
    e.set_defaults(run=_export)

    m = sub.add_parser("compare", help="compare a run's joints with a reference (TRC, C3D, another run, ground truth)",
                       description=(
        "Compare a finished run's joint centres with a reference's (a marker system's or another tracker's, "
        "as TRC or C3D, another run's results folder, or a sequence's ground truth), frame by frame at the "
        "reference's times: per joint the raw error, the error once its constant offset is removed in the "
        "world, and once removed in the reference's own body frame (from its pelvis, neck and hips), which a "
        "difference of joint-centre conventions needs when the person turns round. Both in one world (one "
        "calibration), or --align."))
    m.add_argument("out", help="the results folder of a `hullcap track` run")
    m.add_argument("reference", help="the reference: a .trc, a .c3d (needs ezc3d), another run's results folder, "
                                     "or a sequence folder with ground truth (truth/ or gt/joints.npz)")
    m.add_argument("--names", metavar="JSON",
                   help="a JSON object mapping our joint names to the reference's (default: the names both have)")
    m.add_argument("--shift", type=_shift, default=0.0, metavar="SECONDS",
                   help="added to the reference's times, for clocks that do not agree (default 0); 'auto': "
                        "the shift within ±1 s under which the joints agree best")
    m.add_argument("--align", action="store_true",
                   help="first move the reference by the rigid motion that lays its joints on ours best (a "
                        "marker system calibrated apart from the cameras)")
    m.add_argument("--up", choices=["y", "z", "pose2sim"], default="y",
                   help="trc: the reference's axes (default y, OpenSim's y up; z: our world; pose2sim: the y-up "
                        "file Pose2Sim writes of a z-up calibration, whose (x, y, z) is our (y, z, x))")
    m.add_argument("--json", help="also write the figures here as JSON")
    m.add_argument("--plot", metavar="PNG", help="also draw the errors over time and per joint here")
    m.set_defaults(run=_compare)
    return ap


def reference() -> str:
    """The command-line reference as Markdown, made from the parser (docs/cli.md)."""
    import contextlib
    import io

    parser = build_parser()
    out = ["# Command-line reference", "", "Generated from the parser by `hullcap._cli.reference()` "
           "(`make docs`); `tests/test_docs.py` checks it is current.", ""]
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            p.print_help()
        out += [f"## hullcap {name}", "", "```text", buf.getvalue().rstrip(), "```", ""]
    return "\n".join(out)


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except (HullcapError, ValueError, OSError) as e:
        print(f"hullcap: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("hullcap: interrupted (a track run resumes where it stopped)", file=sys.stderr)
        return 130
