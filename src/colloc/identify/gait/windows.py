"""Windows of whole strides smoothed one by one, here or on other processes.

Given the controller, the windows of a walking record are independent: each is smoothed
alone (:class:`~colloc.identify.gait.smoother.GaitSmoother`, its own states and start), and
only their smoothed signals meet again, in the schedule's fit. A :class:`WindowJob` holds
what one window needs and nothing that cannot travel (no CasADi object: a worker builds the
model once per process, :func:`gait_dynamics`), so the jobs can be handed to any ``map``: the
built-in one, or a Dask client's (``colloc gait identify --workers``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from colloc.data.split import stride_windows, take_rows
from colloc.data.trial import Trial
from colloc.identify.gait.read import subject
from colloc.identify.gait.settings import GaitIdentifySettings
from colloc.identify.gait.smoother import GaitSmoother
from colloc.identify.gait.smoother_results import SmoothedGait
from colloc.identify.gait.smoother_settings import SmootherSettings

Progress = Callable[[str, str], None]
#: ``map_windows(function, jobs) -> results`` in the jobs' order.
WindowMap = Callable[[Callable[[Any], Any], list[Any]], list[Any]]


@functools.lru_cache(maxsize=4)
def gait_dynamics(body_mass: float, height: float) -> Any:
    """gait2d with a subject's segment parameters, built once per process.

    Parameters
    ----------
    body_mass, height : float
        [kg], [m].

    Returns
    -------
    GaitDynamics
    """
    from colloc.gait.orbit import GaitDynamics
    from colloc.models.gait2d_params import load_parameters

    return GaitDynamics.build(load_parameters(float(body_mass), float(height)))


@dataclass(frozen=True)
class WindowJob:
    """One window of a trial to smooth.

    Attributes
    ----------
    trial : Trial
        The record the window is in (:func:`colloc.data.read_trial`).
    rows : ndarray of int
        The window's consecutive samples.
    label : str
        How progress reports name it (``"stride window 2/5, "``).
    body_mass, height : float
        The subject, for the model's segment parameters.
    settings : SmootherSettings or None
        None: the source's own defaults (:data:`SOURCES`).
    source : str
        What the smoother tracks, a key of :data:`SOURCES`: ``markers`` (the lab's raw
        markers and plates, :func:`colloc.identify.gait.markers.marker_smoother`),
        ``markers-only`` (the markers alone) or ``angles`` (the trial's angles, trunk and
        torques, :meth:`GaitSmoother.from_trial`).
    noise : tuple of (str, float)
        A source that tracks markers: noise levels replacing the trial's estimates (``marker``,
        ``force``, ``moment``, ``torque_prior``; :class:`colloc.identify.gait.markers.MarkerNoise`).
    fit_places : bool
        A source that tracks markers: estimate each marker's place in its segment with the
        motion (:func:`colloc.identify.gait.markers.marker_smoother`'s ``fit_places``).
    """

    trial: Any
    rows: np.ndarray
    label: str
    body_mass: float
    height: float
    settings: SmootherSettings | None = None
    source: str = "angles"
    noise: tuple[tuple[str, float], ...] = ()
    fit_places: bool = False


def _angle_smoother(dynamics: Any, job: WindowJob) -> tuple[GaitSmoother, dict[str, Any]]:
    smoother = GaitSmoother.from_trial(dynamics, job.trial, job.rows, job.settings)
    return smoother, {"tracked": "angles"}


def _marker_smoother(
    dynamics: Any, job: WindowJob, use_plates: bool = True
) -> tuple[GaitSmoother, dict[str, Any]]:
    from colloc.identify.gait.markers import marker_smoother

    return marker_smoother(
        dynamics,
        job.trial,
        job.rows,
        job.settings,
        noise=dict(job.noise),
        use_plates=use_plates,
        fit_places=job.fit_places,
    )


@dataclass(frozen=True)
class SmoothingSource:
    """What a smoother tracks, and what follows from it.

    Attributes
    ----------
    build : callable
        ``build(dynamics, job) -> (smoother, facts)`` for one window.
    words : str
        How messages name what it tracks.
    lab_markers : bool
        It tracks a lab's raw markers: the trial must carry them, and the torques are the
        smoother's own (no measurement whose noise the trial records).
    """

    build: Callable[[Any, WindowJob], tuple[GaitSmoother, dict[str, Any]]]
    words: str
    lab_markers: bool


#: ``--smooth-from`` (but ``auto``) -> what the smoother tracks. ``markers-only`` is the
#: lab's markers without its plates: what the plates add to the estimate and its bound is
#: the difference between the two.
SOURCES: dict[str, SmoothingSource] = {
    "angles": SmoothingSource(_angle_smoother, "trial's angles, trunk pose and torques", False),
    "markers": SmoothingSource(_marker_smoother, "lab's raw markers and plates", True),
    "markers-only": SmoothingSource(
        functools.partial(_marker_smoother, use_plates=False),
        "lab's raw markers alone (its plates not tracked)",
        True,
    ),
}


def smoothing_source(requested: str, trial: Any) -> str:
    """The source a run smooths from: ``requested``, or for ``auto`` the lab's markers and
    plates when the trial carries markers, else its angles.

    Raises
    ------
    ValueError
        When a source of :data:`SOURCES` that tracks markers is asked of a trial without them,
        or ``requested`` is none of ``auto`` and :data:`SOURCES`.
    """
    from colloc.identify.gait.markers import has_markers

    if requested == "auto":
        return "markers" if has_markers(trial) else "angles"
    if requested not in SOURCES:
        raise ValueError(
            f"smooth_from: expected 'auto' or one of {list(SOURCES)}, found {requested!r}"
        )
    if SOURCES[requested].lab_markers and not has_markers(trial):
        raise ValueError(
            f"smooth_from: {requested!r} needs a lab trial with its raw markers (markers.csv, "
            "as colloc gait trial-from-lab writes it); this trial has none (--smooth-from "
            "angles)"
        )
    return requested


def smooth_window(job: WindowJob, progress: Progress | None = None) -> SmoothedGait:
    """Smooth one window; the result pickles without its CasADi problem.

    Parameters
    ----------
    job : WindowJob
    progress : callable, optional
        ``progress(stage, detail)``, each detail prefixed by the job's label.

    Returns
    -------
    SmoothedGait

    Raises
    ------
    SmootherError
        When a stage of the window's smoother does not converge.
    """
    dynamics = gait_dynamics(job.body_mass, job.height)
    smoother, facts = SOURCES[job.source].build(dynamics, job)

    def report(stage: str, detail: str) -> None:
        if progress is not None:
            progress(stage, f"{job.label}{detail}")

    result = smoother.run(progress=report)
    if SOURCES[job.source].lab_markers:
        from colloc.identify.gait.markers import fitted_places, tracking_fit

        facts = {**fitted_places(facts, result), "fit": tracking_fit(result.problem, result.z)}
    result.tracking = facts
    return result


def smooth_windows(
    jobs: list[WindowJob],
    progress: Progress | None = None,
    map_windows: WindowMap | None = None,
) -> list[SmoothedGait]:
    """Smooth every window: one after another in this process (with each stage's progress),
    or through ``map_windows`` (each window's end reported as it is gathered).

    Parameters
    ----------
    jobs : list of WindowJob
    progress : callable, optional
    map_windows : callable, optional
        ``map_windows(smooth_window, jobs)``, e.g. a Dask client's map and gather.

    Returns
    -------
    list of SmoothedGait
        In the jobs' order.
    """
    if map_windows is None:
        return [smooth_window(job, progress) for job in jobs]
    results = list(map_windows(smooth_window, jobs))
    if progress is not None:
        for job, result in zip(jobs, results, strict=True):
            progress("windows", f"{job.label}{result.stages[-1].describe()}")
    return results


def window_facts(result: Any) -> dict[str, Any]:
    """What one smoothed window cost, where it ran and what it tracked (the summary's
    ``windows``)."""
    return {
        "tracking": getattr(result, "tracking", {}),
        "start": float(result.times[0]),
        "stop": float(result.times[-1]),
        "nodes": int(result.times.size),
        "iterations": int(sum(s.iterations for s in result.stages)),
        "seconds": float(result.seconds),
        "process": result.process,
    }


def fit_windows(
    settings: GaitIdentifySettings, times: np.ndarray, strikes: np.ndarray
) -> list[tuple[int, int]]:
    """The smoother's windows of a record: all of it, or ``settings.window_strides``."""
    if settings.window_strides is None:
        return [(0, times.size)]
    return stride_windows(times, strikes, settings.window_strides)


def window_jobs(
    part: Trial,
    rows: np.ndarray,
    windows: list[tuple[int, int]],
    meta: dict[str, Any],
    name: str,
    source: str = "angles",
    noise: tuple[tuple[str, float], ...] = (),
    fit_places: bool = False,
) -> list[Any]:
    """One smoothing job per window of ``part``'s samples ``rows`` (each its own samples
    alone: what travels to a worker), each smoothing from ``source`` (:data:`SOURCES`)
    with the noise levels ``noise`` and, with ``fit_places``, the markers' places estimated
    with the motion (sources that track markers).

    Raises
    ------
    ValueError
        When ``fit_places`` is asked of a source that tracks no markers.
    """
    if fit_places and not SOURCES[source].lab_markers:
        raise ValueError(
            f"fit_places: the markers' places are estimated by a smoother that tracks them; "
            f"this one tracks the {SOURCES[source].words} (smooth from 'markers' on a lab "
            "trial)"
        )
    body = subject(meta)
    return [
        WindowJob(
            take_rows(part, rows[first:stop]),
            np.arange(stop - first),
            "" if len(windows) == 1 else f"{name} {k + 1}/{len(windows)}, ",
            *body,
            source=source,
            noise=tuple(noise),
            fit_places=bool(fit_places),
        )
        for k, (first, stop) in enumerate(windows)
    ]


def prefixed(say: Progress, step: str) -> Progress:
    """``say`` under ``step``, each stage's name leading its report."""

    def report(stage: str, detail: str) -> None:
        say(step, f"{stage}: {detail}")

    return report
