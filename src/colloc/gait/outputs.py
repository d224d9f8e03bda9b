"""Output files of a synthetic walking trial: figures, animation, summary, atomic publishing.

Layout of the output directory (see :func:`colloc.gait.workflow.simulate_trial`)::

    <out>/
        trial/              trial.csv, events.csv, metadata.yaml (colloc.data.trial)
        cycle.npz           the periodic cycle (WalkingCycle.to_npz)
        joint_angles.png    joint angles by gait cycle, mean ± sd (measured)
        contact_forces.png  contact forces over the first seconds (true)
        walking.gif         stick-figure animation of the first seconds
        summary.json        wall times per step, strides, fell flag, hip height range, files

Items are written into a staging directory first and then moved into place by renames
(:func:`publish`), the summary last.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from colloc.data.columns import JOINT_ANGLE_COLUMNS
from colloc.data.trial import replace_refusal
from colloc.models.gait2d import CONTACT_POINT_NAMES
from colloc.models.gait2d_points import StickFigureGeometry
from colloc.plot.common import save_figure
from colloc.plot.gait import plot_contact_forces, plot_joint_angles_by_cycle
from colloc.plot.gait_animation import animate_gait
from colloc.store.ids import package_versions

TRIAL_DIR = "trial"
CYCLE_FILE = "cycle.npz"
SUMMARY_FILE = "summary.json"
ANIMATION_FILE = "walking.gif"
FIGURE_STEMS = ("joint_angles", "contact_forces")
#: Output file name -> key of :attr:`GaitSimulationResult.files`.
OUTPUT_KEYS = {
    TRIAL_DIR: "trial",
    CYCLE_FILE: "cycle",
    **{f"{stem}.png": stem for stem in FIGURE_STEMS},
    ANIMATION_FILE: "animation",
    SUMMARY_FILE: "summary",
}


def write_json(value: Any, path: Path) -> None:
    """Write ``value`` as indented JSON to ``path`` under a temporary name, then rename."""
    temporary = path.with_name(f".{path.name}.{secrets.token_hex(8)}.part")
    try:
        temporary.write_text(json.dumps(value, indent=2, default=_json_default), encoding="utf-8")
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def publish(staging: Path, out: Path, names: list[str]) -> dict[str, Path]:
    """Move the named items of ``staging`` into ``out`` by renames, in the given order.

    A directory replaces its namesake through a rename to a backup first, so that at every
    moment either the old or the new complete directory is in place; it replaces only a
    folder that holds a trial's files alone (:func:`colloc.data.trial.replace_refusal`), and
    when one is refused nothing is moved.

    Parameters
    ----------
    staging : Path
        Directory holding the complete new items.
    out : Path
        Destination directory.
    names : list of str
        Item names, moved in this order (put the summary last).

    Returns
    -------
    dict
        Name -> new path.
    """
    refusals = [
        refusal
        for name in names
        if (staging / name).is_dir() and (refusal := replace_refusal(out / name)) is not None
    ]
    if refusals:  # nothing moved yet: the old outputs and the user's files stay as they are
        raise FileExistsError("; ".join(refusals))
    moved = {}
    for name in names:
        source, target = staging / name, out / name
        if source.is_dir():
            backup = out / f".{name}.old-{secrets.token_hex(8)}"
            if target.exists():
                target.rename(backup)
            try:
                source.rename(target)
            except BaseException:
                if backup.exists() and not target.exists():
                    backup.rename(target)
                raise
            shutil.rmtree(backup, ignore_errors=True)
        else:
            os.replace(source, target)
        moved[name] = target
    return moved


#: Cycle statistics copied into the summary when present (see colloc.gait.settle).
_CYCLE_STATS = ("source", "settle_residual", "hip_drift_per_stride", "num_strides", "cycle_nodes")


def summarize(
    settings: Mapping[str, Any],
    record: Any,
    cycle: Any,
    design_info: Any,
    timings: Mapping[str, float],
    files: Mapping[str, str],
    notes: list[str],
) -> dict[str, Any]:
    """The content of ``summary.json``.

    Parameters
    ----------
    settings : mapping
        ``GaitSimulationSettings.to_dict()``.
    record : ClosedLoopRecord
        ``times``, ``states``, ``right_heel_strikes``, ``left_heel_strikes``, ``fell``,
        ``message`` and ``stats["compiled"]`` (whether the walk's right-hand side was
        compiled to C, as ``walk_compiled``).
    cycle : WalkingCycle
    design_info : DesignInfo or None
        Its ``spectral_radius`` and ``extra["tuning"]`` are reported when present.
    timings : mapping
        Step -> wall time [s].
    files : mapping
        Output name -> path relative to ``out``.
    notes : list of str
        Anything that did not go as planned (e.g. a figure that could not be drawn).

    Returns
    -------
    dict
        JSON-ready summary.
    """
    hip_height = np.asarray(record.states, dtype=float)[:, 1]
    right = np.asarray(record.right_heel_strikes, dtype=float)
    left = np.asarray(record.left_heel_strikes, dtype=float)
    times = np.asarray(record.times, dtype=float)
    radius = getattr(design_info, "spectral_radius", None)
    stats = getattr(cycle, "stats", {}) or {}
    return {
        "settings": dict(settings),
        "simulated_seconds": float(times[-1] - times[0]),
        "fell": bool(record.fell),
        "message": str(record.message),
        "strides": {"right": max(right.size - 1, 0), "left": max(left.size - 1, 0)},
        "hip_height_range": [float(hip_height.min()), float(hip_height.max())],
        "cycle": {
            "speed": float(cycle.belt_speed),
            "duration": float(cycle.duration),
            **{k: stats[k] for k in _CYCLE_STATS if k in stats},
        },
        "controller_spectral_radius": None if radius is None else float(radius),
        "controller_tuning": dict(getattr(design_info, "extra", {}).get("tuning", {})),
        "wall_times": {name: float(value) for name, value in timings.items()},
        "walk_compiled": bool((getattr(record, "stats", {}) or {}).get("compiled", False)),
        "files": dict(files),
        "notes": list(notes),
        "package_versions": package_versions(),
    }


def write_figures(
    trial: Any, record: Any, directory: Path, window: float, notes: list[str]
) -> list[str]:
    """Draw the PNG figures into ``directory``; a figure that cannot be drawn becomes a note.

    Parameters
    ----------
    trial : Trial
        Joint angles by gait cycle come from its (measured) angles and heel strikes, each
        leg normalised to its own strides.
    record : ClosedLoopRecord
        Contact forces come from its ``times`` and ``contact_forces``.
    directory : Path
        Where the PNG files go.
    window : float
        Seconds of contact forces shown, from the start.
    notes : list of str
        Gains one entry per figure that could not be drawn (e.g. too few strides).

    Returns
    -------
    list of str
        File names written.
    """
    written = []
    strikes = [trial.right_heel_strikes] * 3 + [trial.left_heel_strikes] * 3
    labels = [name.replace("_angle", "").replace("_", " ") for name in JOINT_ANGLE_COLUMNS]
    try:
        figure = plot_joint_angles_by_cycle(
            trial.time, trial.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy(), strikes, labels
        )
    except ValueError as error:
        notes.append(f"joint-angle figure not drawn: {error}")
    else:
        save_figure(figure, directory, FIGURE_STEMS[0], formats=("png",))
        written.append(f"{FIGURE_STEMS[0]}.png")
    start = float(record.times[0])
    force_names = [f"{p.replace('_', ' ')} F{a}" for p in CONTACT_POINT_NAMES for a in "xy"]
    figure = plot_contact_forces(
        record.times, record.contact_forces, force_names, window=(start, start + window)
    )
    save_figure(figure, directory, FIGURE_STEMS[1], formats=("png",))
    written.append(f"{FIGURE_STEMS[1]}.png")
    return written


def write_animation(record: Any, geometry: StickFigureGeometry, path: Path, seconds: float) -> Path:
    """Animate the first ``seconds`` of the record's motion (GIF at 30 frames per second).

    Parameters
    ----------
    record : ClosedLoopRecord
        ``times``, ``states`` (its first 9 columns are the coordinates), ``belt_position``.
    geometry : StickFigureGeometry
    path : Path
        The ``.gif`` file.
    seconds : float
        Length of the animation [s].

    Returns
    -------
    Path
        ``path``.
    """
    fps = 30
    return animate_gait(
        record.times,
        np.asarray(record.states)[:, :9],
        geometry,
        path,
        belt_position=record.belt_position,
        fps=fps,
        max_frames=max(1, int(seconds * fps)),
    )
