"""The smoother that tracks a lab's raw markers and force plates, not its filtered angles.

A lab trial (:func:`colloc.lab.trial_from_lab`) keeps its markers' unfiltered positions and
the plates at their own rate (:mod:`colloc.data.tables`). Here each marker becomes a point
fixed in its gait2d segment (:mod:`colloc.models.gait2d_markers`) and each plate the
contact model's force and moment under its foot, so the smoother's objective is the
likelihood of what the lab measured:

* each marker's ``x`` and ``y`` at the nodes, weighted by ``1 / sigma_marker^2`` (samples
  where it was not seen are left out, not filled);
* each foot's forward and vertical force and its moment about the origin on the floor
  (the centre of pressure times the vertical force), the sum over the heel and toe
  contact points, weighted by the plate's noise. A plate recorded faster than the markers
  is averaged over each node's sampling interval (``[t_k - h/2, t_k + h/2)``), its noise
  divided by the square root of the samples averaged. Until the contact reaches the model's
  own slip scale the plates weigh a hundredth (:data:`EARLY_PLATE_WEIGHT`); a last stage
  tracks them at their full weight.

The joint torques carry a weak prior: each sample near the trial's inverse-dynamics torque
with a standard deviation of :data:`TORQUE_PRIOR_STD` (20 N m, four to six times the
inverse dynamics' own error on a simulated walk). Markers at 100 Hz say little about a
torque's fast changes: without a prior the continuation of the contact failed within its
first step on 4 s of a simulated walk, and a prior centred on zero (50-100 N m) left the
torques 10-43 N m RMS from the truth where the inverse dynamics is 3-6 N m off; with this
one every step converged and the angles came 2-2.5 times closer to the truth than the
inverse kinematics'. Apart from that prior, the trial's filtered angles only make the
zero-defect start (:meth:`GaitSmoother.start`) and the markers' positions in their
segments. Those positions are the least-squares fixed points
of the start's segments (:func:`colloc.models.gait2d_markers.local_positions`); the thigh
and shank lengths are the markers' mean joint-to-joint distances, so that the landmarks
on the joints stay on them, and the ankle's height above the sole is the one the loaded feet
show (:func:`colloc.lab.ankle.ankle_height`, recorded by the lab), so that the model's sole meets the floor where the subject's
does.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import sympy as sm

from colloc.data.columns import (
    JOINT_ANGLE_COLUMNS,
    SIDES,
    TIME_COLUMN,
    TORQUE_COLUMNS,
    TRUNK_COLUMNS,
)
from colloc.data.tables import marker_names
from colloc.identify.gait.smoother import GaitSmoother
from colloc.identify.gait.smoother_settings import SmootherSettings
from colloc.identify.gait.trial_noise import trial_noise_std
from colloc.lab.ankle import ankle_height
from colloc.model.symbols import name_of

#: Marker noise [m] used when the record shows none (a noise-free synthetic export).
DEFAULT_MARKER_STD = 1e-3
#: Plate noise [N] and [N m] used when the record shows none.
DEFAULT_FORCE_STD, DEFAULT_MOMENT_STD = 2.0, 1.0


def marker_settings() -> SmootherSettings:
    """The marker smoother's default settings: the trapezoidal rule, whose nodes hold the
    dynamics, so that the plates tracked at the nodes are the forces the dynamics feel.
    Under the midpoint rule the node speeds carry its odd-even mode, which the contact
    forces at the nodes feel and the dynamics do not: on 4 s of a simulated walk with
    plates tracked the midpoint rule left the torques 7-27 N m RMS from the truth, the
    trapezoidal rule 5-8 (angles 0.09-0.21 deg; the inverse kinematics' 0.18-0.74)."""
    from colloc.transcription import Trapezoidal

    return SmootherSettings(scheme=Trapezoidal())


#: Factor on the plates' weights before the smoother's last stage (their standard deviations
#: ten times larger): at the smoothed contact (v_s = 0.1 m/s) the model cannot make the
#: plates' forces, and at full weight backward Euler diverged on a 10 s window of a simulated
#: walk (defects 3.7e3 after 82 iterations); at a tenth of their standard deviation's weight
#: it converged in 34 iterations, against 182 without plates.
EARLY_PLATE_WEIGHT = 0.01

#: Standard deviation [N m] of the joint torques' prior about the inverse dynamics, per
#: sample (see the module's description).
TORQUE_PRIOR_STD = 20.0

#: Standard deviation [m] of the prior about each marker coordinate's starting place in its
#: segment when the places are estimated with the motion (``fit_places``): wide against the
#: millimetres the record determines them to, narrow enough to hold a direction it does not.
PLACE_PRIOR_STD = 0.01


@dataclass(frozen=True)
class MarkerNoise:
    """The noise levels the marker smoother weighs its signals by.

    Attributes
    ----------
    marker : float
        Each marker coordinate's standard deviation [m].
    force, moment : float
        Each plate sample's force [N] and moment [N m] standard deviations.
    torque_prior : float
        The joint torques' prior about the inverse dynamics [N m].
    source : str
        Where the numbers came from (the trial's estimate, a default, the caller).
    """

    marker: float
    force: float
    moment: float
    torque_prior: float
    source: str

    @classmethod
    def from_metadata(
        cls, meta: Mapping[str, Any], overrides: Mapping[str, float] | None = None
    ) -> MarkerNoise:
        """The trial's estimates (``markers: noise_std_m``, ``plates: force_noise_std_n``,
        ``moment_noise_std_nm``), a default where it records none or zero, and
        ``overrides`` (``marker``, ``force``, ``moment``, ``torque_prior``) above both.

        Raises
        ------
        ValueError
            When an override is not a positive number or names another quantity.
        """
        markers = _section(meta, "markers")
        plates = _section(meta, "plates")
        values = {
            "marker": (markers.get("noise_std_m"), DEFAULT_MARKER_STD),
            "force": (plates.get("force_noise_std_n"), DEFAULT_FORCE_STD),
            "moment": (plates.get("moment_noise_std_nm"), DEFAULT_MOMENT_STD),
            "torque_prior": (None, TORQUE_PRIOR_STD),
        }
        given = dict(overrides or {})
        unknown = sorted(set(given) - set(values))
        bad = [f"{k}={v!r}" for k, v in given.items() if not _positive(v)]
        if unknown or bad:
            raise ValueError(
                "noise: expected positive numbers for marker, force, moment, torque_prior; found "
                + ", ".join([f"unknown {k}" for k in unknown] + bad)
            )
        chosen, said = {}, []
        for key, (recorded, default) in values.items():
            if key in given:
                chosen[key] = float(given[key])
                said.append(f"{key} given")
            elif _positive(recorded):
                chosen[key] = float(recorded)  # type: ignore[arg-type]
                said.append(f"{key} estimated from the record")
            else:
                chosen[key] = default
                said.append(
                    f"{key} colloc's default"
                    + ("" if key == "torque_prior" else " (the record shows none)")
                )
        return cls(
            chosen["marker"],
            chosen["force"],
            chosen["moment"],
            chosen["torque_prior"],
            "; ".join(said),
        )


def _section(meta: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    found = meta.get(key)
    return found if isinstance(found, Mapping) else {}


def _positive(value: Any) -> bool:
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and bool(np.isfinite(value))
        and value > 0
    )


def has_markers(trial: Any) -> bool:
    """Whether a trial carries the lab's raw markers and their segments."""
    segments = trial.metadata.get("markers", {})
    return "markers" in getattr(trial, "tables", {}) and isinstance(segments, Mapping)


def markers_on_nodes(table: pd.DataFrame, times: np.ndarray) -> dict[str, np.ndarray]:
    """Each marker's samples at the node times (a node no sample falls on within a hundredth
    of a step is NaN: left out).

    Returns
    -------
    dict
        Marker name -> (N, 2).
    """
    stamp = table[TIME_COLUMN].to_numpy(dtype=float)
    h = float(np.median(np.diff(times)))
    k = np.clip(np.searchsorted(stamp, times), 1, stamp.size - 1)
    nearest = np.where(np.abs(stamp[k - 1] - times) <= np.abs(stamp[k] - times), k - 1, k)
    hit = np.abs(stamp[nearest] - times) <= 0.01 * h
    out = {}
    for name in marker_names(table):
        xy = table[[f"{name}_x", f"{name}_y"]].to_numpy(dtype=float)[nearest]
        xy[~hit] = np.nan
        out[name] = xy
    return out


def plates_on_nodes(table: pd.DataFrame, times: np.ndarray) -> tuple[np.ndarray, float]:
    """The plates averaged over each node's sampling interval ``[t_k - h/2, t_k + h/2)``.

    Returns
    -------
    values : ndarray, shape (N, 6)
        Per node, :data:`colloc.data.tables.PLATE_COLUMNS` (NaN where no sample fell).
    samples : float
        The median number of plate samples per node (the noise's divisor is its root).
    """
    stamp = table[TIME_COLUMN].to_numpy(dtype=float)
    values = table.drop(columns=TIME_COLUMN).to_numpy(dtype=float)
    h = float(np.median(np.diff(times)))
    edges = np.concatenate([times - 0.5 * h, [times[-1] + 0.5 * h]])
    cell = np.searchsorted(edges, stamp, side="right") - 1
    inside = (cell >= 0) & (cell < times.size)
    counts = np.bincount(cell[inside], minlength=times.size).astype(float)
    sums = np.stack(
        [np.bincount(cell[inside], values[inside, j], times.size) for j in range(values.shape[1])],
        axis=1,
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        out = sums / counts[:, None]
    return out, float(np.median(counts[counts > 0])) if (counts > 0).any() else 0.0


def measured_lengths(meta: Mapping[str, Any]) -> dict[str, float]:
    """The thigh and shank lengths the trial's markers give (the mean of both sides), from
    its ``lab: segment_lengths_m``: the standing trial's (``static``) where the lab had one,
    else the walk's (``measured``); empty when it records none."""
    lengths = _section(meta, "lab").get("segment_lengths_m")
    if not isinstance(lengths, Mapping):
        return {}
    out = {}
    for segment in ("thigh", "shank"):
        entries = [lengths.get(f"{side}_{segment}") for side in SIDES]
        key = (
            "static"
            if all(isinstance(e, Mapping) and "static" in e for e in entries)
            else "measured"
        )
        found = [float(e[key]) for e in entries if isinstance(e, Mapping) and key in e]
        if found and all(_positive(v) for v in found):
            out[segment] = float(np.mean(found))
    return out


def marker_outputs(
    gait: Any,
    segments: Mapping[str, str],
    local: Mapping[str, Any],
    names: Any = None,
) -> dict[tuple[str, int], tuple[sm.Basic, sm.Expr]]:
    """Each marker coordinate as the smoother's output: a point fixed in its segment.

    Parameters
    ----------
    gait : Gait2D
    segments : mapping
        Marker name -> its gait2d segment.
    local : mapping
        Marker name -> ``(a, b)``, its position in the segment's frame [m].
    names : iterable of str, optional
        The markers, in this order (default ``local``'s).

    Returns
    -------
    dict
        ``(name, 0 or 1)`` (``x`` or ``y``) -> (output symbol ``marker_<name>_<x|y>(t)``,
        its expression in the coordinates).
    """
    from sympy.physics.mechanics import dynamicsymbols

    from colloc.models.gait2d_markers import marker_position

    out = {}
    for name in local if names is None else names:
        position = marker_position(gait, segments[name], tuple(local[name]))
        for k, axis in enumerate("xy"):
            out[(name, k)] = (dynamicsymbols(f"marker_{name}_{axis}"), position[k])
    return out


def plate_outputs(gait: Any) -> list[tuple[sm.Basic, sm.Expr]]:
    """Each foot's plate as the contact model gives it, in the order of
    :data:`colloc.data.tables.PLATE_COLUMNS` (per side: forward force, vertical force and
    the moment about the origin on the floor, the heel's and toe's contact summed).

    Parameters
    ----------
    gait : Gait2D

    Returns
    -------
    list of (output symbol ``plate_<side>_<force_x|force_y|moment>(t)``, expression)
    """
    from sympy.physics.mechanics import dynamicsymbols

    out = []
    for side in SIDES:
        forces = [gait.contact_forces[f"{side}_{p}"] for p in ("heel", "toe")]
        points = [gait.contact_points[f"{side}_{p}"] for p in ("heel", "toe")]
        fx = sum((f[0] for f in forces), sm.Integer(0))
        fy = sum((f[1] for f in forces), sm.Integer(0))
        moment = sum(
            (pt[0] * f[1] - pt[1] * f[0] for pt, f in zip(points, forces, strict=True)),
            sm.Integer(0),
        )
        for label, expression in (("force_x", fx), ("force_y", fy), ("moment", moment)):
            out.append((dynamicsymbols(f"plate_{side}_{label}"), expression))
    return out


def marker_smoother(
    dynamics: Any,
    trial: Any,
    rows: np.ndarray,
    settings: SmootherSettings | None = None,
    use_plates: bool = True,
    noise: Mapping[str, float] | None = None,
    fit_places: bool = False,
) -> tuple[GaitSmoother, dict[str, Any]]:
    """The smoother of the samples ``rows`` of a lab trial that tracks its raw markers and
    plates (see the module's description).

    Parameters
    ----------
    dynamics : GaitDynamics
    trial : Trial
        With a ``markers`` table and its segments (:func:`has_markers`).
    rows : ndarray of int
        Consecutive sample indices.
    settings : SmootherSettings, optional
        Default :func:`marker_settings`.
    use_plates : bool
        Track the plates too (default, when the trial has them). Without them the ankle's
        height is still the one the lab recorded, if it did.
    noise : mapping, optional
        ``marker`` [m], ``force`` [N], ``moment`` [N m] replacing the trial's estimates,
        ``torque_prior`` [N m] replacing :data:`TORQUE_PRIOR_STD`.
    fit_places : bool
        Estimate each marker's place in its segment with the motion (two parameters per
        marker, ``place_<name>_a`` and ``_b``), started from the static trial's or the walk's
        least-squares place and held by a Gaussian prior of :data:`PLACE_PRIOR_STD` about
        it; :func:`fitted_places` then reads the estimates and how far the record alone
        determines each. False (default): the places stay where they start.

    Returns
    -------
    smoother : GaitSmoother
    facts : dict
        What it tracks: markers and their positions in their segments, the noise levels
        and where they came from, the segment lengths, the plates' samples per node.

    Raises
    ------
    ValueError
        When the trial has no markers, a marker names an unknown segment or is never seen,
        or a noise override is not a positive number.
    """
    from colloc.models.gait2d_markers import local_positions

    if not has_markers(trial):
        raise ValueError(
            "trial: expected a lab trial with its raw markers (markers.csv and the markers' "
            "segments in metadata.yaml, as colloc gait trial-from-lab writes them); found none"
        )
    lacking = [c for c in TORQUE_COLUMNS if c not in trial.signals.columns]
    if lacking:
        raise ValueError(
            f"trial: expected the inverse dynamics' torques beside the markers (the torques' "
            f"prior), found no {', '.join(lacking)}"
        )
    rows = np.asarray(rows)
    times = trial.time[rows]
    meta = trial.metadata
    levels = MarkerNoise.from_metadata(meta, noise)
    segments = dict(meta["markers"].get("segments", {}))
    markers = markers_on_nodes(trial.tables["markers"], times)
    missing = sorted(set(markers) - set(segments))
    if missing:
        raise ValueError(f"markers: no segment recorded for {', '.join(missing)}")
    gait = dynamics.gait
    s = gait.segment_symbols
    lengths = measured_lengths(meta)
    constants = {getattr(s, f"l_{k}"): v for k, v in lengths.items()}
    # The ankle's height the lab recorded is the subject's, with or without tracking plates;
    # only a trial written before the lab recorded it has it read from the plates here.
    height = meta["markers"].get("ankle_height_m")
    if _positive(height) or (use_plates and "plates" in trial.tables):
        if not _positive(height):
            height = ankle_height(
                trial.tables["markers"],
                trial.tables["plates"],
                segments,
                float(meta.get("body_mass", 75.0)),
                float(dynamics.constants[gait.contact_symbols.stiffness]),
            )
        if height is not None:
            constants[s.h_ankle] = height
            lengths["ankle_height"] = height
    p = np.array([{**dynamics.constants, **constants}[c] for c in gait.constants])
    signals = trial.signals.iloc[rows]
    pose = signals[list(TRUNK_COLUMNS + JOINT_ANGLE_COLUMNS)].to_numpy(dtype=float)
    standing = {
        name: np.asarray(xy, dtype=float)
        for name, xy in dict(meta["markers"].get("in_segment_m") or {}).items()
        if name in markers
    }
    walked = {name: xy for name, xy in markers.items() if name not in standing}
    local = {**standing, **(local_positions(gait, p, pose, walked, segments) if walked else {})}
    placed_from = {
        name: (
            str(meta["markers"].get("in_segment_from", "the static trial"))
            if name in standing
            else "the walk's inverse kinematics (least squares over the window)"
        )
        for name in markers
    }
    tracked: dict[sm.Basic, tuple[sm.Expr, np.ndarray, float]] = {}
    symbols = place_symbols(markers) if fit_places else {}
    placed = {name: symbols.get(name, local[name]) for name in markers}
    for (name, k), (y, expression) in marker_outputs(gait, segments, placed, markers).items():
        tracked[y] = (expression, markers[name][:, k], levels.marker)
    inverse_dynamics = signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float)
    for k, torque in enumerate(gait.torques):
        tracked[torque] = (torque, inverse_dynamics[:, k], levels.torque_prior)
    samples, plate_signals = 0.0, []
    if use_plates and "plates" in trial.tables:
        plates, samples = plates_on_nodes(trial.tables["plates"], times)
        shrink = 1.0 / np.sqrt(max(samples, 1.0))
        for j, (y, expression) in enumerate(plate_outputs(gait)):
            std = levels.moment if j % 3 == 2 else levels.force
            tracked[y] = (expression, plates[:, j], std * shrink)
            plate_signals.append(y)
    smoother = GaitSmoother(
        dynamics,
        times,
        pose,
        signals["belt_speed"].to_numpy(dtype=float),
        np.array([trial_noise_std(meta, c) for c in TRUNK_COLUMNS + JOINT_ANGLE_COLUMNS]),
        settings=settings if settings is not None else marker_settings(),
        tracked=tracked,
        track_positions=False,
        constants=constants,
        early_weights=dict.fromkeys(plate_signals, EARLY_PLATE_WEIGHT),
        node_mean_inputs=True,
        output_parameters={
            symbol: (float(local[name][k]), PLACE_PRIOR_STD)
            for name, pair in symbols.items()
            for k, symbol in enumerate(pair)
        },
        parameter_update=(
            PlaceUpdate(gait, p, markers, segments, local, symbols, levels.marker)
            if fit_places
            else None
        ),
    )
    facts = {
        "tracked": "markers and plates" if samples else "markers",
        "markers": {
            name: {
                "segment": segments[name],
                "in_segment_m": [float(v) for v in local[name]],
                "from": placed_from[name],
            }
            for name in markers
        },
        "noise": {
            "marker_m": levels.marker,
            "force_n": levels.force,
            "moment_nm": levels.moment,
            "torque_prior_nm": levels.torque_prior,
            "source": levels.source,
        },
        "segment_lengths_m": lengths,
        # the same, by the gait2d constant each sets (what a bound of this design needs)
        "constants": {str(symbol): float(value) for symbol, value in constants.items()},
        "plate_samples_per_node": samples,
        "places_fitted": bool(fit_places),
    }
    return smoother, facts


def place_symbols(names: Any) -> dict[str, tuple[sm.Symbol, sm.Symbol]]:
    """Each marker's place in its segment as two parameters, ``place_<name>_a`` (along the
    segment's ``x`` axis) and ``place_<name>_b`` (its ``y`` axis) [m].

    Parameters
    ----------
    names : iterable of str

    Returns
    -------
    dict
        Marker name -> ``(a, b)`` symbols.
    """
    return {name: sm.symbols(f"place_{name}_a place_{name}_b") for name in names}


class PlaceUpdate:
    """The markers' places given the smoothed motion: per marker coordinate, the weighted
    least squares of its samples seen, ``R(angle)^T (marker - origin)``, with the prior of
    :data:`PLACE_PRIOR_STD` about its start (exact, the marker being linear in its place).

    Parameters
    ----------
    gait : Gait2D
    constants : ndarray
        The smoother's :meth:`Gait2D.constant_array` (its segment lengths).
    markers : mapping
        Marker name -> its samples at the nodes ``(N, 2)``, NaN where not seen.
    segments : mapping
        Marker name -> its segment.
    start : mapping
        Marker name -> the prior's mean ``(a, b)`` [m].
    symbols : mapping
        Marker name -> its place's symbols (:func:`place_symbols`).
    marker_std : float
        Each coordinate's noise [m].
    """

    def __init__(
        self,
        gait: Any,
        constants: np.ndarray,
        markers: Mapping[str, np.ndarray],
        segments: Mapping[str, str],
        start: Mapping[str, Any],
        symbols: Mapping[str, tuple[sm.Symbol, sm.Symbol]],
        marker_std: float,
    ) -> None:
        self.gait, self.constants = gait, np.asarray(constants, dtype=float)
        self.markers, self.segments = dict(markers), dict(segments)
        self.start = {name: np.asarray(start[name], dtype=float) for name in symbols}
        self.symbols = dict(symbols)
        self.seen = {
            name: float(np.all(np.isfinite(xy), axis=1).sum()) for name, xy in self.markers.items()
        }
        self.marker_std = float(marker_std)

    def __call__(self, states: np.ndarray) -> dict[sm.Symbol, float]:
        """The places given the node states ``(N, 18)``, by symbol."""
        from colloc.models.gait2d_markers import local_positions

        means = local_positions(
            self.gait, self.constants, np.asarray(states)[:, :9], self.markers, self.segments
        )
        out: dict[sm.Symbol, float] = {}
        prior = 1.0 / PLACE_PRIOR_STD**2
        for name, pair in self.symbols.items():
            data = self.seen[name] / self.marker_std**2
            place = (data * np.asarray(means[name]) + prior * self.start[name]) / (data + prior)
            out.update(zip(pair, (float(v) for v in place), strict=True))
        return out


def fitted_places(facts: Mapping[str, Any], result: Any) -> dict[str, Any]:
    """The marker smoother's facts with the places it estimated (``fit_places=True``): each
    marker's ``in_segment_m`` the estimate, ``start_m`` where it began, and
    ``record_share`` per coordinate, ``1 - (sd / prior_sd)^2``: the share of the place's
    information that the record (markers, plates, dynamics) gives rather than the prior.
    Near 1 the record determines the place; near 0 only the prior holds it, as for a rigid
    motion of all of one segment's markers that trades with that segment's pose where no
    joint further down the chain tells them apart.

    Parameters
    ----------
    facts : mapping
        :func:`marker_smoother`'s.
    result : SmoothedGait
        Its smoother's result (:attr:`SmoothedGait.parameters` and ``parameter_sd``).

    Returns
    -------
    dict
        ``facts`` updated (unchanged when the places were not fitted); ``place_sd_m`` per
        marker gives the posterior standard deviations (the Cramer-Rao bound of the
        smoother's design at the estimate), or ``place_sd_note`` says there are none.
    """
    if not facts.get("places_fitted"):
        return dict(facts)
    markers = {name: dict(entry) for name, entry in facts["markers"].items()}
    out: dict[str, Any] = {**facts, "markers": markers}
    estimates, spread = result.parameters, result.parameter_sd
    for name, entry in markers.items():
        names = [name_of(v) for v in place_symbols([name])[name]]
        entry["start_m"] = entry["in_segment_m"]
        entry["in_segment_m"] = [float(estimates[n]) for n in names]
        entry["from"] = "estimated with the motion, started from " + str(entry["from"])
        if spread:
            entry["place_sd_m"] = [spread[n] for n in names]
            entry["record_share"] = [
                float(max(0.0, 1.0 - (spread[n] / PLACE_PRIOR_STD) ** 2)) for n in names
            ]
    if not spread:
        out["place_sd_note"] = "no standard deviations: see the window's notes"
    return out


def tracking_fit(problem: Any, z: np.ndarray) -> dict[str, float]:
    """How closely a marker smoother's solution follows what it tracks: the RMS over the
    samples seen of the markers' coordinates [mm], the plates' forces [N] and moments
    [N m], and the torques' distance from their prior [N m].

    Parameters
    ----------
    problem : Problem
        The smoother's last problem.
    z : ndarray
        Its solution.

    Returns
    -------
    dict
        ``marker_rms_mm``, ``plate_force_rms_n``, ``plate_moment_rms_nm``,
        ``torque_from_prior_rms_nm`` (those present).
    """
    from colloc.nlp.residuals import tracking_residuals

    groups: dict[str, list[np.ndarray]] = {}
    for signal in tracking_residuals(problem, z, "tracking"):
        name = signal.name
        if name.startswith("marker_"):
            key = "marker_rms_mm"
        elif name.startswith("plate_"):
            key = "plate_moment_rms_nm" if name.endswith("moment") else "plate_force_rms_n"
        else:
            key = "torque_from_prior_rms_nm"
        groups.setdefault(key, []).append(signal.residuals[np.isfinite(signal.residuals)])
    scale = {"marker_rms_mm": 1e3}
    return {
        key: float(scale.get(key, 1.0) * np.sqrt(np.mean(np.concatenate(parts) ** 2)))
        for key, parts in groups.items()
    }
