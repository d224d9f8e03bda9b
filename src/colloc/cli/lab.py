"""``colloc gait trial-from-lab``: a lab's marker and force-plate exports to a gait trial."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from colloc.cli.common import number, output_problems, path_arg, report_problems

COMMAND = "colloc gait trial-from-lab"


def _names(text: str) -> list[str]:
    names = [name.strip() for name in text.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(f"expected names separated by commas, found {text!r}")
    return names


def _pairs(text: str) -> dict[str, str]:
    """``right=FP2,left=FP1`` -> {"right": "FP2", "left": "FP1"}."""
    pairs = {}
    for item in text.split(","):
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise argparse.ArgumentTypeError(f"expected KEY=NAME[,KEY=NAME...], found {text!r}")
        pairs[key.strip()] = value.strip()
    return pairs


def _belt(text: str) -> float | str:
    """A number is a constant speed [m/s]; anything else names a column."""
    try:
        return float(text)
    except ValueError:
        if not text.strip():
            raise argparse.ArgumentTypeError("expected a speed or a column name") from None
        return text.strip()


def add_parser(gs: Any) -> None:
    """Add ``trial-from-lab`` to the ``colloc gait`` subcommands ``gs``."""
    p = gs.add_parser(
        "trial-from-lab",
        help="make a gait trial of a lab's marker and force-plate exports: gaps filled, "
        "zero-lag filter, planar inverse kinematics and dynamics, heel strikes",
    )
    p.add_argument(
        "markers",
        type=path_arg,
        help="the motion capture: C3D, OpenSim TRC, or a tab or comma export (a C3D or an "
        "export may hold the plates too); the format is read from the content",
    )
    p.add_argument(
        "--forces",
        type=path_arg,
        default=None,
        help="the force plates, if in a file of their own: OpenSim MOT/STO, C3D or an export",
    )
    p.add_argument(
        "--grf-xml",
        type=path_arg,
        default=None,
        metavar="XML",
        help="OpenSim's ExternalLoads file (the _grf.xml) naming each MOT plate's foot (by "
        "default a plate goes to the foot whose markers its centre of pressure lies under)",
    )
    p.add_argument(
        "--static",
        type=path_arg,
        default=None,
        metavar="FILE",
        help="the standing trial (TRC or C3D): landmarks the walk lacks (epicondyles, "
        "malleoli) are taken from it and carried by their segment's marker cluster",
    )
    p.add_argument(
        "--track",
        choices=("markers", "landmarks"),  # colloc.lab.markers.TRACKED_MARKERS
        default="markers",
        help="what the trial keeps, unfiltered, for the marker smoother: 'markers', the "
        "markers the record holds (the clusters and pelvis markers when the landmarks are "
        "made from them); 'landmarks', the landmarks themselves, carried by the clusters and "
        "regressed from the pelvis (default: %(default)s)",
    )
    p.add_argument(
        "--static-positions",
        action="store_true",
        help="with --static: place the tracked markers in their segments, and size the thigh "
        "and shank, from the standing trial instead of from the walk's own inverse kinematics "
        "(either way the standing trial's values are recorded in the trial's metadata)",
    )
    p.add_argument(
        "--forward",
        default=None,
        metavar="AXIS",
        help="walking direction in a 3-D file's axes, e.g. +x or -z (default: found from the "
        "markers' motion)",
    )
    p.add_argument("--mass", type=number, required=True, help="body mass, kg")
    p.add_argument("--height", type=number, required=True, help="body height, m")
    p.add_argument(
        "--belt-speed",
        type=_belt,
        required=True,
        metavar="M/S|COLUMN",
        help="treadmill belt speed: a constant in m/s (0 overground) or the export's column",
    )
    p.add_argument("--out", type=path_arg, required=True, help="trial folder to write")
    p.add_argument("--overwrite", action="store_true", help="replace an existing trial folder")
    p.add_argument(
        "--cutoff",
        type=number,
        default=None,
        metavar="HZ",
        help="zero-lag low-pass cut-off (-3 dB) for markers and forces (default 6 Hz)",
    )
    p.add_argument(
        "--max-gap",
        type=number,
        default=None,
        metavar="S",
        help="longest marker gap filled by a smoothing spline (default 0.25 s)",
    )
    p.add_argument(
        "--strike-threshold",
        type=number,
        default=None,
        metavar="N",
        help="vertical force whose upward crossing is a heel strike (default 100 N, as "
        "colloc's simulated trials)",
    )
    p.add_argument(
        "--columns",
        type=_names,
        default=None,
        metavar="NAMES",
        help="column names of a marker file without a header line, separated by commas",
    )
    p.add_argument(
        "--force-columns",
        type=_names,
        default=None,
        metavar="NAMES",
        help="column names of a force file without a header line",
    )
    p.add_argument(
        "--plates",
        type=_pairs,
        default=None,
        metavar="SIDE=NAME,...",
        help="the plate under each foot (default right=FP2,left=FP1)",
    )
    p.add_argument(
        "--prefixes",
        type=_pairs,
        default=None,
        metavar="SIDE=PREFIX,...",
        help="marker name prefix per side (default right=R,left=L)",
    )
    p.add_argument(
        "--marker-names",
        type=_pairs,
        default=None,
        metavar="LANDMARK=NAME,...",
        help="marker names without the side prefix, for the landmarks shoulder, hip, knee, "
        "ankle, heel, toe (default SHO, GTRO, LEK, LM, HEE, MT5)",
    )
    p.add_argument(
        "--keep-zeros",
        action="store_true",
        help="marker coordinates of exactly 0 are data (by default a sample at 0, 0 is missing)",
    )


def trial_from_lab_checks(args: argparse.Namespace) -> tuple[Any, list[str]]:
    """The settings of ``colloc gait trial-from-lab`` and every problem found before any work.

    Parameters
    ----------
    args : argparse.Namespace

    Returns
    -------
    settings : LabSettings or None
        None when the marker names or plates are themselves invalid.
    problems : list of str
    """
    from colloc.lab.markers import LANDMARKS, MarkerSet
    from colloc.lab.settings import LabSettings

    problems = []
    names: dict[str, Any] = dict(args.marker_names or {})
    unknown = sorted(set(names) - set(LANDMARKS))
    if unknown:
        problems.append(
            f"--marker-names: unknown landmarks {unknown}, expected some of {list(LANDMARKS)}"
        )
        names = {}
    if args.prefixes is not None:
        names["prefixes"] = args.prefixes
    if args.plates is not None:
        names["plates"] = args.plates
    try:
        marker_set = MarkerSet(**names)
    except ValueError as error:
        problems.append(f"--prefixes/--plates: {error}")
        marker_set = MarkerSet()
    # flags left out take the settings' defaults (defined once, in LabSettings)
    given = {
        "cutoff_hz": args.cutoff,
        "max_gap": args.max_gap,
        "strike_threshold": args.strike_threshold,
    }
    settings = LabSettings(
        body_mass=args.mass,
        height=args.height,
        belt_speed=args.belt_speed,
        marker_set=marker_set,
        zeros_are_missing=not args.keep_zeros,
        **{key: value for key, value in given.items() if value is not None},
    )
    flags = {
        "body_mass": "--mass",
        "height": "--height",
        "belt_speed": "--belt-speed",
        "cutoff_hz": "--cutoff",
        "max_gap": "--max-gap",
        "strike_threshold": "--strike-threshold",
    }
    for problem in settings.problems():
        key = problem.split(":", 1)[0]
        problems.append(f"{flags.get(key, key)}{problem[len(key) :]}")
    for flag, path in (
        ("markers", args.markers),
        ("--forces", args.forces),
        ("--grf-xml", args.grf_xml),
        ("--static", args.static),
    ):
        if path is not None and not path.is_file():
            problems.append(f"{flag} {str(path)!r}: no such file")
    if args.forward is not None:
        from colloc.lab.sagittal import parse_axis

        try:
            parse_axis(args.forward)
        except ValueError as error:
            problems.append(f"--{error}")
    problems += _out_problems(args)
    return settings, problems


def _out_problems(args: argparse.Namespace) -> list[str]:
    """What stops ``--out`` from taking the trial, found before any work: a folder that is
    not a trial colloc may replace (it may hold the inputs or someone's files), or a place
    that cannot be written."""
    from colloc.data.trial import replace_refusal

    out = args.out
    inputs = [
        ("markers", args.markers),
        ("--forces", args.forces),
        ("--grf-xml", args.grf_xml),
        ("--static", args.static),
    ]
    for flag, path in inputs:
        if path is not None and _inside(path, out):
            return [
                f"--out {str(out)!r}: holds the {flag} file {str(path)!r}; the trial is "
                "written to a folder of its own, choose another --out"
            ]
    if out.exists() or out.is_symlink():
        if not args.overwrite:
            return [f"--out {str(out)!r}: exists; give --overwrite to replace it"]
        refusal = replace_refusal(out)
        if refusal is not None:
            return [f"--out: {refusal}"]
    # the trial is staged beside the folder and renamed into place: the parent takes the writes
    return output_problems(None, out.absolute().parent)


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies below it (links resolved)."""
    resolved, root = path.resolve(), folder.resolve()
    return resolved == root or root in resolved.parents


def run(args: argparse.Namespace) -> int:
    """``colloc gait trial-from-lab``: check, process, write, report."""
    from colloc.lab.exports import LabFileError
    from colloc.lab.from_files import trial_from_lab

    settings, problems = trial_from_lab_checks(args)
    if report_problems(COMMAND, problems):
        return 2
    try:
        result = trial_from_lab(
            args.markers,
            settings,
            args.forces,
            names=args.columns,
            force_names=args.force_columns,
            mapping=args.grf_xml,
            forward=args.forward,
            static=args.static,
            track=args.track,
            static_positions=args.static_positions,
        )
    except LabFileError as error:
        report_problems(COMMAND, [f"{error.source}: {p}" for p in error.problems])
        return 2
    path = result.trial.write(Path(args.out), overwrite=args.overwrite)
    trial = result.trial
    filled = [g for g in result.gaps if g.filled]
    noise = trial.metadata["noise"]["std"]
    print(f"trial: {path}")
    print(
        f"  {trial.time.size} samples, {trial.time[0]:g}-{trial.time[-1]:g} s at "
        f"{trial.metadata['sample_rate']:g} Hz; heel strikes: {trial.right_heel_strikes.size} "
        f"right, {trial.left_heel_strikes.size} left"
    )
    longest = max((g.samples for g in filled), default=0)
    print(
        f"  gaps filled: {len(filled)} (longest {longest} samples); filter {settings.cutoff_hz:g} Hz"
    )
    print(
        f"  noise estimated: joint angles {math.degrees(noise['joint_angle']):.2f} deg, trunk "
        f"position {noise['trunk_position'] * 1000:.2f} mm, forces {noise['ground_reaction_force']:.1f} N"
    )
    for note in result.notes:
        print(f"note: {note}")
    return 0
