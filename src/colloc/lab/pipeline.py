"""From a lab's marker and force-plate exports to a colloc gait trial.

The steps a gait lab takes, each stated in the trial's metadata (``lab``):

1. read the exports (:func:`colloc.lab.exports.read_lab_export`), markers and plates by the
   lab's names (:class:`colloc.lab.markers.MarkerSet`);
2. fill each marker's interior gaps up to ``max_gap`` by a smoothing spline and cut the record to
   where every marker was seen (:func:`colloc.lab.gaps.fill_gaps`);
3. low-pass filter markers and plate signals alike, zero lag, -3 dB at ``cutoff_hz``
   (:func:`colloc.data.filtering.zero_lag_lowpass`);
4. planar inverse kinematics: trunk pose from the hip and shoulder markers (both sides'
   mean), each side's hip, knee and ankle angles in gait2d's conventions, rates by central
   differences (:mod:`colloc.lab.kinematics`);
5. inverse dynamics of each leg with gait2d's segments for the subject's mass and height and
   the plate under its foot (:mod:`colloc.lab.dynamics`);
6. heel strikes where a foot's filtered vertical force rises through ``strike_threshold``;
   centre of pressure ``MomZ / ForY`` where the foot is loaded;
7. the tracked markers' unfiltered positions (gaps left as gaps) and the plates at their own
   rate kept beside the signals (:mod:`colloc.lab.raw_tables`), for the smoother that tracks
   them: the landmarks, or the clusters and skin markers they were made from.

The noise levels the identification weighs the signals by are estimated from the record
itself: the robust spread (1.4826 times the median absolute deviation) of the unfiltered minus
the filtered signal, per group of columns, so that impacts do not count as noise; a plate's
from the second differences of its samples where its foot is off it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid

from colloc.data.columns import (
    BELT_COLUMNS,
    GRF_COLUMNS,
    JOINT_ANGLE_COLUMNS,
    JOINT_RATE_COLUMNS,
    SIDES,
    SIGNAL_COLUMNS,
    TORQUE_COLUMNS,
    TRUNK_COLUMNS,
    TRUNK_RATE_COLUMNS,
)
from colloc.data.events import detect_heel_strikes
from colloc.data.filtering import (
    DEFAULT_ORDER,
    design_cutoff,
    time_derivative,
    zero_lag_lowpass,
)
from colloc.data.trial import Trial
from colloc.gait.strikes import UNLOADED_FORCE
from colloc.gait.trials import DEFAULT_NOISE_STD
from colloc.lab.ankle import ankle_height
from colloc.lab.dynamics import LegInertia, leg_inverse_dynamics
from colloc.lab.exports import LabExport, LabFileError
from colloc.lab.gaps import GAP_CONTEXT, Gap, fill_gaps
from colloc.lab.kinematics import joint_angles, segment_orientation, segment_orientations
from colloc.lab.markers import LANDMARKS, MarkerSet
from colloc.lab.noise import off_plate_noise, robust_sd
from colloc.lab.plausibility import (
    MAX_MARKER_SPEED,
    belt_problems,
    cutoff_problems,
    gravity_problems,
    spikes,
    threshold_problems,
)
from colloc.lab.raw_tables import landmark_segments, marker_table, raw_records, tracked_positions
from colloc.lab.sagittal import plates_under_feet
from colloc.lab.settings import LabSettings, check_settings
from colloc.models.gait2d_markers import SEGMENTS
from colloc.models.gait2d_params import Gait2DParameters, load_parameters
from colloc.store.ids import package_versions

#: Largest change of a segment's marker length over the record [m] before the markers are
#: taken to be swapped or misplaced (leg2d's check).
MAX_LENGTH_CHANGE = 0.1

#: Relative difference between a segment's measured mean length and the model's (from the
#: height) above which the trial carries a note.
LENGTH_NOTE_FRACTION = 0.15

#: Samples cut from each end of the trial, in half periods of the cut-off: there the filter
#: runs off the record, and what happens at an end (a force or a motion) is smeared into the
#: second derivatives. Measured on a simulated walk starting with a 528 N friction transient
#: in its first sample: the left hip torque 590 N m from the truth at t = 0, 397, 228, 116
#: and 34 N m over the next four samples, then the record's usual 10-30 N m.
EDGE_HALF_PERIODS = 1.0


@dataclass(frozen=True)
class LabResult:
    """A trial made from a lab record, and what was done to make it.

    Attributes
    ----------
    trial : Trial
        Ready to write (:meth:`colloc.data.Trial.write`) and identify.
    gaps : list of Gap
        Every marker gap, filled or cut off.
    notes : list of str
        What a user should know (cut ends, segment lengths far from the model's, ...).
    """

    trial: Trial
    gaps: list[Gap]
    notes: list[str]


def process_lab(
    markers: LabExport,
    settings: LabSettings,
    forces: LabExport | None = None,
    tracked: dict[str, str] | None = None,
) -> LabResult:
    """Make a gait trial of lab exports already read.

    Parameters
    ----------
    markers : LabExport
        Markers (and the plates, when ``forces`` is None).
    settings : LabSettings
    forces : LabExport, optional
        The plates, on their own time stamps.
    tracked : dict, optional
        The markers the trial keeps unfiltered for the marker smoother, each with the gait2d
        segment it moves with (:data:`colloc.models.gait2d_markers.SEGMENTS`): the clusters
        and skin markers the landmarks were made from
        (:func:`colloc.lab.landmarks.landmark_record`). By default the landmarks themselves.

    Returns
    -------
    LabResult

    Raises
    ------
    ValueError
        As :func:`trial_from_lab`, every problem at once.
    """
    if not isinstance(markers, LabExport) or not (forces is None or isinstance(forces, LabExport)):
        found = type(markers if not isinstance(markers, LabExport) else forces).__name__
        raise TypeError(f"markers, forces: expected LabExport (read_lab_export), found {found}")
    check_settings(settings)
    problems = settings.problems()
    ms = settings.marker_set
    needed = [ms.marker(side, landmark) for side in SIDES for landmark in LANDMARKS]
    lacking = [name for name in needed if name not in markers.markers]
    if lacking:
        problems.append(
            f"markers: {', '.join(lacking)} not in {markers.source or 'the export'} (found "
            f"{', '.join(sorted(markers.markers)) or 'none'}); name the markers with marker_set= (on "
            "the command line --marker-names and --prefixes)"
        )
    plates = forces if forces is not None else markers
    absent = [ms.plates[side] for side in SIDES if ms.plates[side] not in plates.plates]
    if absent:
        problems.append(
            f"plates: {', '.join(absent)} not in {plates.source or 'the export'} (found "
            f"{', '.join(sorted(plates.plates)) or 'none'}); each foot needs its plate"
        )
    belt_column = settings.belt_speed if isinstance(settings.belt_speed, str) else None
    columns = {**markers.columns, **(forces.columns if forces is not None else {})}
    if belt_column is not None and belt_column not in columns:
        problems.append(
            f"belt_speed: no column {belt_column!r} in the exports (found "
            f"{', '.join(sorted(columns)) or 'none'})"
        )
    if tracked is not None:
        problems += _tracked_problems(tracked, markers)
    unit_notes: list[str] = []
    if not problems:
        params = load_parameters(settings.body_mass, settings.height)
        markers, unit_notes = _metres(markers, ms, params)
        problems += gravity_problems(markers, plates, ms)
        problems += cutoff_problems(settings.cutoff_hz, markers.sample_rate, "markers")
        problems += cutoff_problems(settings.cutoff_hz, plates.sample_rate, "plates")
        if not problems:
            problems += _plate_side_problems(markers, plates, ms)
    if problems:
        raise LabFileError("lab record", problems)
    fs = markers.sample_rate
    wanted = {name: markers.markers[name].copy() for name in needed}
    for name, rows in spikes(wanted, fs).items():
        wanted[name][rows] = np.nan
        unit_notes.append(
            f"marker {name}: {rows.size} sample(s) jump away and back faster than "
            f"{MAX_MARKER_SPEED:g} m/s (first at t = {markers.time[rows[0]]:g} s): taken as "
            "missing and filled"
        )
    filled, gaps, span = fill_gaps(markers.time, wanted, settings.max_gap)
    time = markers.time[span]
    notes = unit_notes + [
        f"marker {g.marker} missing at the {'start' if g.start <= markers.time[0] else 'end'} "
        f"({g.samples} samples): the record is cut to {time[0]:g}-{time[-1]:g} s"
        for g in gaps
        if not g.filled
    ]
    raw = {name: xy[span] for name, xy in filled.items()}
    kept_rows = np.arange(markers.time.size)[span]
    smooth = {name: zero_lag_lowpass(xy, fs, settings.cutoff_hz) for name, xy in raw.items()}
    loads = _plate_loads(plates, time, settings, ms)
    belt = _belt_speed(settings, columns, markers, forces, time)

    def landmarks(source: dict[str, np.ndarray], side: str) -> dict[str, np.ndarray]:
        return {landmark: source[ms.marker(side, landmark)] for landmark in LANDMARKS}

    def mean_of_sides(source: dict[str, np.ndarray], landmark: str) -> np.ndarray:
        right, left = (source[ms.marker(side, landmark)] for side in SIDES)
        return np.asarray(0.5 * (right + left))

    trunk = {}
    for label, source in (("raw", raw), ("smooth", smooth)):
        hip, shoulder = mean_of_sides(source, "hip"), mean_of_sides(source, "shoulder")
        trunk[label] = np.column_stack([hip, segment_orientation(hip, shoulder, (0.0, 1.0))])
    angles: dict[str, list[np.ndarray]] = {"raw": [], "smooth": []}
    torques = []
    params = load_parameters(settings.body_mass, settings.height)
    inertia = LegInertia.from_parameters(params)
    for side in SIDES:
        oriented = {}
        for label, source in (("raw", raw), ("smooth", smooth)):
            oriented[label] = segment_orientations(landmarks(source, side))
            oriented[label]["trunk"] = trunk[label][:, 2]
            angles[label].append(joint_angles(oriented[label]))
        leg = leg_inverse_dynamics(
            landmarks(smooth, side), oriented["smooth"], loads[side]["smooth"], inertia, fs
        )
        torques.append(leg.torques)
    joint = np.column_stack(angles["smooth"])
    signals = pd.DataFrame(
        np.column_stack(
            [
                joint,
                time_derivative(joint, fs),
                trunk["smooth"],
                belt,
                cumulative_trapezoid(belt, time, initial=0.0),
                time_derivative(trunk["smooth"], fs),
                np.column_stack(torques),
                *(_ground_reaction(loads[side]["smooth"]) for side in SIDES),
            ]
        ),
        columns=list(
            JOINT_ANGLE_COLUMNS
            + JOINT_RATE_COLUMNS
            + TRUNK_COLUMNS
            + BELT_COLUMNS
            + TRUNK_RATE_COLUMNS
            + TORQUE_COLUMNS
            + GRF_COLUMNS
        ),
    )[list(SIGNAL_COLUMNS)]
    vertical = {side: loads[side]["smooth"][:, 1] for side in SIDES}
    evidence = threshold_problems(settings.strike_threshold, vertical)
    evidence += belt_problems(
        {side: smooth[ms.marker(side, "heel")] for side in SIDES}, vertical, fs, belt
    )
    if evidence:
        raise LabFileError("lab record", evidence)
    strikes = {
        side: detect_heel_strikes(time, vertical[side], settings.strike_threshold) for side in SIDES
    }
    edge = int(np.ceil(EDGE_HALF_PERIODS * fs / (2.0 * settings.cutoff_hz)))
    if time.size > 2 * edge + 2:
        keep = slice(edge, time.size - edge)
        notes.append(
            f"the first and last {edge} samples ({edge / fs:.3g} s) are cut: there the "
            f"{settings.cutoff_hz:g} Hz filter runs off the record's ends, and the torques "
            "from its second derivatives are not to be trusted"
        )
        kept_rows = kept_rows[keep]
        time = time[keep]
        signals = signals.iloc[keep].reset_index(drop=True)
        strikes = {side: s[(s >= time[0]) & (s <= time[-1])] for side, s in strikes.items()}
    length_problems, lengths, length_notes = _segment_lengths(smooth, ms, params)
    if length_problems:
        raise LabFileError("lab record", length_problems)
    notes += length_notes
    noise = _noise(angles, trunk, loads, raw, smooth, settings)
    notes += [
        f"noise of {group}: none measurable in the record (its samples vary by exactly 0 "
        f"where the noise is read, as a plate written as exact zeros in swing does): colloc's "
        f"default {DEFAULT_NOISE_STD[group]:g} is used; set it if you know better"
        for group in noise["unmeasured"]
    ]
    landmarks_raw = {name: xy[kept_rows] for name, xy in wanted.items()}
    if tracked is None:
        segments, kept, marker_std = landmark_segments(ms), landmarks_raw, noise["marker_std"]
    else:
        kept, marker_std, spike_notes = tracked_positions(
            markers.time,
            {name: markers.markers[name] for name in tracked},
            kept_rows,
            fs,
            settings.cutoff_hz,
        )
        segments = dict(tracked)
        notes += spike_notes
    metadata = {
        "sample_rate": float(f"{fs:.9g}"),  # not 99.99999999999991 from the time stamps
        "body_mass": float(settings.body_mass),
        "height": float(settings.height),
        "noise": noise,
        "lab": _processing(settings, fs, gaps, time, lengths, strikes, notes),
        "package_versions": package_versions(),
    }
    tables, recorded = raw_records(time, kept, segments, plates, ms, marker_std)
    height = ankle_height(
        marker_table(time, landmarks_raw),
        tables["plates"],
        landmark_segments(ms),
        settings.body_mass,
        params.contact.stiffness,
        params.gravity,
    )
    if height is not None:
        recorded["markers"]["ankle_height_m"] = height
    metadata.update(recorded)
    trial = Trial(time, signals, strikes["right"], strikes["left"], metadata, tables)
    trial.validate()
    return LabResult(trial=trial, gaps=gaps, notes=notes)


def _tracked_problems(tracked: Any, markers: LabExport) -> list[str]:
    """What is wrong with the markers asked to be tracked: not a mapping of names in the
    export to gait2d's segments."""
    if not isinstance(tracked, dict) or not tracked:
        return [f"tracked: expected a mapping of marker -> segment, found {tracked!r}"]
    absent = sorted(str(n) for n in tracked if n not in markers.markers)
    unknown = sorted({str(s) for s in tracked.values() if s not in SEGMENTS})
    out = []
    if absent:
        out.append(f"tracked: {', '.join(absent)} not in {markers.source or 'the export'}")
    if unknown:
        out.append(f"tracked: segments expected among {list(SEGMENTS)}, found {unknown}")
    return out


def _metres(
    markers: LabExport, ms: MarkerSet, params: Gait2DParameters
) -> tuple[LabExport, list[str]]:
    """Markers in metres: a planar export whose thighs measure about a thousand (or a hundred)
    times the model's is in millimetres (centimetres), converted with a note."""
    lengths = [
        np.nanmedian(
            np.linalg.norm(
                markers.markers[ms.marker(s, "knee")] - markers.markers[ms.marker(s, "hip")], axis=1
            )
        )
        for s in SIDES
    ]
    ratio = float(np.nanmedian(lengths)) / params.thigh.length
    for unit, scale in (("mm", 1e-3), ("cm", 1e-2)):
        if 0.3 / scale < ratio < 3.0 / scale:
            planar = {name: xy * scale for name, xy in markers.markers.items()}
            note = (
                f"markers in {unit}: the thighs' markers lie {np.nanmedian(lengths):.0f} apart "
                f"against the model's {params.thigh.length:.3f} m; converted to m"
            )
            return replace(markers, markers=planar), [note]
    return markers, []


def _plate_side_problems(markers: LabExport, plates: LabExport, ms: MarkerSet) -> list[str]:
    """The plates named for each foot must carry that foot: their centres of pressure lie
    between its heel and toe markers while loaded (a swapped pair of plates, one plate
    named for both feet, or a free torque read as the moment all fail here)."""
    named = {name: side for side, name in ms.plates.items()}
    chosen = LabExport(plates.time, {}, {n: plates.plates[n] for n in named}, source=plates.source)
    found, problems = plates_under_feet(markers, chosen, ms)
    wrong = {name: side for name, side in found.items() if side != named[name]}
    if wrong:
        problems.append(
            "plates: "
            + "; ".join(
                f"{name} is named for the {named[name]} foot but its centre of pressure lies "
                f"under the {side} foot's markers"
                for name, side in wrong.items()
            )
            + f" (--plates {','.join(f'{s}={n}' for s, n in ms.plates.items())}): the plates "
            "or the markers' sides are swapped"
        )
    return problems


def _plate_loads(
    plates: LabExport, time: np.ndarray, settings: LabSettings, ms: MarkerSet
) -> dict[str, dict[str, np.ndarray]]:
    """Each foot's ``Fx, Fy, Mz`` on the marker times, filtered and unfiltered."""
    out = {}
    rate = plates.sample_rate
    if time[0] < plates.time[0] - 0.5 / rate or time[-1] > plates.time[-1] + 0.5 / rate:
        raise LabFileError(
            "lab record",
            [
                f"plates: the force export covers {plates.time[0]:g}-{plates.time[-1]:g} s, "
                f"the markers {time[0]:g}-{time[-1]:g} s; the forces must cover the markers"
            ],
        )
    for side in SIDES:
        channels = plates.plates[ms.plates[side]]
        smooth = zero_lag_lowpass(channels, rate, settings.cutoff_hz)
        out[side] = {
            label: np.column_stack([np.interp(time, plates.time, values[:, k]) for k in range(3)])
            for label, values in (("raw", channels), ("smooth", smooth))
        }
    return out


def _belt_speed(
    settings: LabSettings,
    columns: dict[str, np.ndarray],
    markers: LabExport,
    forces: LabExport | None,
    time: np.ndarray,
) -> np.ndarray:
    if not isinstance(settings.belt_speed, str):
        return np.full(time.size, float(settings.belt_speed))
    name = settings.belt_speed
    source = markers if name in markers.columns else forces
    assert source is not None  # the column was found in one of them
    values = source.columns[name]
    if not np.all(np.isfinite(values)):
        raise LabFileError(
            "lab record",
            [f"belt_speed: column {name!r} has {int((~np.isfinite(values)).sum())} NaN"],
        )
    smooth = zero_lag_lowpass(values, source.sample_rate, settings.cutoff_hz)
    return np.interp(time, source.time, smooth)


def _ground_reaction(load: np.ndarray) -> np.ndarray:
    """``grf_x, grf_y, cop_x`` of one foot; the centre of pressure NaN while unloaded."""
    loaded = load[:, 1] >= UNLOADED_FORCE
    cop = np.full(len(load), np.nan)
    cop[loaded] = load[loaded, 2] / load[loaded, 1]
    return np.column_stack([load[:, 0], load[:, 1], cop])


def _segment_lengths(
    smooth: dict[str, np.ndarray], ms: MarkerSet, params: Gait2DParameters
) -> tuple[list[str], dict[str, Any], list[str]]:
    """Swapped-marker check and the measured lengths against the model's."""
    model = {
        "thigh": params.thigh.length,
        "shank": params.shank.length,
        "foot": params.toe_x - params.heel_x,
    }
    pairs = {"thigh": ("hip", "knee"), "shank": ("knee", "ankle"), "foot": ("heel", "toe")}
    problems, notes, lengths = [], [], {}
    for side in SIDES:
        for segment, (a, b) in pairs.items():
            length = np.linalg.norm(smooth[ms.marker(side, b)] - smooth[ms.marker(side, a)], axis=1)
            mean = float(length.mean())
            lengths[f"{side}_{segment}"] = {"measured": mean, "model": float(model[segment])}
            change = float(np.max(np.abs(length - mean)))
            if change > MAX_LENGTH_CHANGE:
                where = float(np.argmax(np.abs(length - mean)))
                problems.append(
                    f"{side} {segment}: the distance {ms.marker(side, a)}-{ms.marker(side, b)} "
                    f"changes by {change:.3f} m (sample {where:.0f}); more than "
                    f"{MAX_LENGTH_CHANGE} m means swapped or misplaced markers"
                )
            if abs(mean / model[segment] - 1.0) > LENGTH_NOTE_FRACTION:
                notes.append(
                    f"{side} {segment}: markers {mean:.3f} m apart, the model's segment for "
                    f"{params.height:g} m is {model[segment]:.3f} m; check the height"
                )
    return problems, lengths, notes


def _noise(
    angles: dict[str, list[np.ndarray]],
    trunk: dict[str, np.ndarray],
    loads: dict[str, dict[str, np.ndarray]],
    raw: dict[str, np.ndarray],
    smooth: dict[str, np.ndarray],
    settings: LabSettings,
) -> dict[str, Any]:
    """Noise levels per trial column group, from the unfiltered minus the filtered signals."""
    joint = robust_sd(
        np.concatenate(
            [(r - s).ravel() for r, s in zip(angles["raw"], angles["smooth"], strict=True)]
        )
    )
    position = robust_sd((trunk["raw"][:, :2] - trunk["smooth"][:, :2]).ravel())
    trunk_angle = robust_sd(trunk["raw"][:, 2] - trunk["smooth"][:, 2])
    # a plate's noise shows where its foot is off it, in the second differences of its
    # samples (white noise: variance 6 sigma^2); the filter's ringing after an impact is not
    # noise, nor are the impacts
    force = off_plate_noise(
        [(loads[side]["raw"][:, :2], loads[side]["smooth"][:, 1]) for side in SIDES]
    )
    bandwidth = 2.0 * np.pi * settings.cutoff_hz
    std = {
        "joint_angle": joint,
        "joint_rate": joint * bandwidth,
        "trunk_position": position,
        "trunk_angle": trunk_angle,
        "trunk_velocity": position * bandwidth,
        "trunk_angle_rate": trunk_angle * bandwidth,
        "ground_reaction_force": force,
    }
    marker = robust_sd(np.concatenate([(raw[n] - smooth[n]).ravel() for n in raw]))
    unmeasured = sorted(group for group, value in std.items() if not value > 0)
    return {
        "std": {
            group: value if value > 0 else DEFAULT_NOISE_STD[group] for group, value in std.items()
        },
        "unmeasured": unmeasured,
        "marker_std": marker,
        "estimated": "1.4826 x the median absolute deviation of the unfiltered minus the "
        "filtered signal (forces: of the second differences / sqrt 6 while the foot is off the "
        "plate); rates: that times 2 pi "
        "cutoff_hz; groups not listed take colloc's default lab noise",
    }


def _processing(
    settings: LabSettings,
    sample_rate: float,
    gaps: list[Gap],
    time: np.ndarray,
    lengths: dict[str, Any],
    strikes: dict[str, np.ndarray],
    notes: list[str],
) -> dict[str, Any]:
    return {
        "filter": {
            "type": "Butterworth low-pass, forward and backward (zero lag)",
            "order_per_pass": DEFAULT_ORDER,
            "cutoff_hz": float(settings.cutoff_hz),
            "design_cutoff_hz": design_cutoff(settings.cutoff_hz, sample_rate),
            "applied_to": "markers, plate forces and moments, belt speed",
        },
        "rates": "central differences of the filtered signals (numpy.gradient, second order)",
        "gaps": {
            "method": "cubic smoothing spline (generalised cross-validation) through the "
            f"marker's seen samples within {GAP_CONTEXT} s (scipy make_smoothing_spline)",
            "max_gap_s": float(settings.max_gap),
            "list": [g.as_dict() for g in gaps],
        },
        "span": [float(time[0]), float(time[-1])],
        "segments": "gait2d (Winter's fractions) scaled by body_mass and height",
        "segment_lengths_m": lengths,
        "marker_set": {
            **{landmark: getattr(settings.marker_set, landmark) for landmark in LANDMARKS},
            "prefixes": dict(settings.marker_set.prefixes),
            "plates": dict(settings.marker_set.plates),
        },
        "belt_speed": settings.belt_speed,
        "heel_strikes": {
            "threshold_n": float(settings.strike_threshold),
            "from": "upward crossings of each plate's filtered vertical force",
            "counts": {side: int(strikes[side].size) for side in SIDES},
        },
        "notes": list(notes),
    }
