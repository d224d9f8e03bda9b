"""The Cramér–Rao bound of the whole design: the schedule with the states unknown.

The bound the schedule's least squares reports (:mod:`colloc.identify.gait.controller_fit`)
takes the fed-back states as known. The fit does not have them: it has tracked signals with
their noise, and motor noise enters the torques before the plant moves the states. The bound
of that design is the one of the closed loop's maximum a posteriori problem (the seed's
closed-loop collocation): gait2d closed by ``T = T*(phi) - K(phi) s + w``, every state free
at every node, the tracked signals weighed by their noise ``1 / sigma^2``, and the motor
noise ``w`` penalised by its own ``1 / sigma_w^2``. Its Gauss-Newton Hessian with the
dynamics as constraints, the states and ``w`` eliminated (:func:`colloc.nlp.kkt.eliminate_states`),
is twice the Fisher information of ``T*`` and ``K``.

Windows of strides are independent given the controller, so the information of a record is
the sum of its windows' (each window's states its own: the joins' few nodes are counted
once less, a bound a little wider than the unbroken record's). Only sparse banded solves and
one dense ``n_p x n_p`` block per window are formed: never the dense right-hand sides of the
whole record.

A lab's design (:class:`LabSignals`) tracks what the lab measured instead of angles and
torques: each marker a point fixed in its segment, each plate the contact model's forces and
moment under its foot (:mod:`colloc.identify.gait.markers`), each weighed by its noise and
left out where it was not seen. No torque is measured there: the torques are known only
through the dynamics, and the bound says what markers and plates can tell of the controller.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class WindowDesign:
    """One window of the design, at its nodes.

    Attributes
    ----------
    times : ndarray, shape (N,)
    states : ndarray, shape (N, 18)
        Where the information is evaluated (the smoothed or true states).
    torques : ndarray, shape (N, 6)
        The joint torques there (they fix the motor noise ``w`` at which the dynamics'
        Jacobian is evaluated).
    belt_speed : ndarray, shape (N,)
    phase : ndarray, shape (N,)
        The controller's unwrapped phase in cycles.
    observed : ndarray of bool, shape (N, n_y), optional
        Which tracked signal was measured at which node, in the order of
        :attr:`ClosedLoopInformation.tracked` (a marker hidden, a plate with no sample there);
        None: every one everywhere.
    """

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    belt_speed: np.ndarray
    phase: np.ndarray
    observed: np.ndarray | None = None


@dataclass(frozen=True)
class LabSignals:
    """What a lab's design tracks, as plain data that travels to a worker.

    Attributes
    ----------
    segments : tuple of (str, str)
        Marker name -> its gait2d segment, in the order the markers are tracked.
    local : tuple of (str, (float, float))
        Marker name -> its position in the segment's frame [m].
    constants : tuple of (str, float)
        Gait2d constants the subject's markers set (segment lengths, the ankle's height),
        by the constant's name.
    marker_std : float
        Each marker coordinate's noise [m].
    plate_std : (float, float) or None
        The plates' force [N] and moment [N m] noise per node (already divided by the root of
        the samples a node averages); None: the plates are not tracked.
    """

    segments: tuple[tuple[str, str], ...]
    local: tuple[tuple[str, tuple[float, float]], ...]
    constants: tuple[tuple[str, float], ...]
    marker_std: float
    plate_std: tuple[float, float] | None

    def outputs(self, gait: Any) -> list[tuple[Any, Any, float]]:
        """The tracked outputs: (symbol, expression, noise), markers (``x``, ``y`` each)
        first, then the plates in the order of :data:`colloc.data.tables.PLATE_COLUMNS`.

        Parameters
        ----------
        gait : Gait2D

        Returns
        -------
        list of (output symbol, expression, standard deviation)
        """
        from colloc.identify.gait.markers import marker_outputs, plate_outputs

        names = [name for name, _ in self.segments]
        markers = marker_outputs(gait, dict(self.segments), dict(self.local), names)
        out = [(y, expression, self.marker_std) for y, expression in markers.values()]
        if self.plate_std is not None:
            force, moment = self.plate_std
            out += [
                (y, expression, moment if j % 3 == 2 else force)
                for j, (y, expression) in enumerate(plate_outputs(gait))
            ]
        return out


class ClosedLoopInformation:
    """The Fisher information of the schedule's parameters from windows of a record, states
    unknown.

    The closed loop's problem is built once per window length (and sampling interval) and
    its known trajectories (belt speed, phase) swapped for each window of that length
    (:meth:`colloc.Problem.replace_data`), so a long record costs one build.

    Parameters
    ----------
    dyn : GaitDynamics
        The plant (:class:`colloc.gait.orbit.GaitDynamics`).
    gs : GainScheduled
        The schedule's structure.
    noise : mapping
        Tracked column (a name of :func:`colloc.identify.gait.read.state_names` or a torque
        column) -> its noise standard deviation per sample.
    motor_noise : float
        Standard deviation of the motor noise per sample and joint [N m], > 0.
    scheme : Scheme, optional
        The transcription (default the midpoint rule, as the closed-loop fit).
    lab : LabSignals, optional
        A lab's markers and plates, tracked beside ``noise``'s columns (which may then be
        empty).

    Raises
    ------
    ValueError
        For a motor noise or tracked noise that is not a positive number, an unknown
        column or constant, or nothing tracked.
    """

    def __init__(
        self,
        dyn: Any,
        gs: Any,
        noise: Mapping[str, float],
        motor_noise: float,
        scheme: Any = None,
        lab: LabSignals | None = None,
    ) -> None:
        from sympy.physics.mechanics import dynamicsymbols

        from colloc.data.columns import TORQUE_COLUMNS
        from colloc.identify.gait.read import state_names
        from colloc.model.symbols import name_of

        if not (np.isfinite(motor_noise) and motor_noise > 0):
            raise ValueError(
                f"motor_noise: expected a standard deviation > 0, found {motor_noise!r}"
            )
        model, gait = dyn.model, dyn.gait
        by_column = dict(zip(state_names(), model.states, strict=True))
        by_column.update(zip(TORQUE_COLUMNS, gait.torques, strict=True))
        unknown = sorted(set(noise) - set(by_column))
        if unknown:
            raise ValueError(f"noise: no tracked signal is named {', '.join(unknown)}")
        bad = {c: v for c, v in noise.items() if not (np.isfinite(v) and v > 0)}
        if bad:
            raise ValueError(f"noise: expected standard deviations > 0, found {bad}")
        self.dyn, self.gs, self.scheme = dyn, gs, scheme
        #: output symbol -> its expression (a column's is the state or torque itself)
        self.outputs: dict[Any, Any] = {by_column[c]: by_column[c] for c in noise}
        self.weights = {by_column[c]: 1.0 / v**2 for c, v in noise.items()}
        self.constants = dict(dyn.constants)
        if lab is not None:
            by_name = {str(c): c for c in self.constants}
            unknown = sorted(name for name, _ in lab.constants if name not in by_name)
            stds = [lab.marker_std, *(lab.plate_std or ())]
            if unknown or not all(np.isfinite(v) and v > 0 for v in stds):
                raise ValueError(
                    "lab: expected gait2d's constants and noise levels > 0, found "
                    + (f"unknown constants {unknown}" if unknown else f"noise {stds}")
                )
            self.constants.update({by_name[name]: value for name, value in lab.constants})
            for y, expression, std in lab.outputs(gait):
                self.outputs[y] = expression
                self.weights[y] = 1.0 / std**2
        if not self.outputs:
            raise ValueError("noise: expected at least one tracked signal, found none")
        self.tracked = list(self.outputs)
        self.motor = {T: dynamicsymbols(f"motor_noise_{name_of(T)}") for T in gait.torques}
        self.motor_noise = float(motor_noise)
        index = {x: i for i, x in enumerate(model.states)}
        self.feedback = [index[x] for x in gs.feedback]
        self._built: dict[tuple[int, float], Any] = {}
        self._order: dict[int, list[int]] = {}  # a built problem's parameters in gs's order

    def _problem(self, window: WindowDesign) -> Any:
        from colloc.nlp.problem import Problem
        from colloc.transcription import Midpoint

        dyn, gs, gait = self.dyn, self.gs, self.dyn.gait
        N = window.times.size
        known = {gait.belt_speed: window.belt_speed, gs.phase: window.phase}
        key = (N, round(float(np.mean(np.diff(window.times))), 9))
        problem = self._built.get(key)
        if problem is None:
            closed = dyn.model.with_outputs(self.outputs).with_disturbances(self.motor)
            problem = Problem(
                closed.close_loop(gs),
                window.times,
                scheme=Midpoint() if self.scheme is None else self.scheme,
                known_trajectories=known,
                known_parameters=self.constants,
                objective=self._objective(window),
                process_noise=dict.fromkeys(self.motor.values(), self.motor_noise),
            )
            self._built[key] = problem
        elif window.observed is None:
            problem.replace_data(known_trajectories=known)
        else:
            problem.replace_data(objective=self._objective(window), known_trajectories=known)
        return problem

    def _objective(self, window: WindowDesign) -> Any:
        """The tracking term: the data's values do not enter the Gauss-Newton information,
        only where it is taken (the tracked values are zeros) and which samples were seen (a
        sample not seen is NaN; a signal seen nowhere in the window weighs nothing)."""
        from colloc.nlp.objective import Tracking

        N = window.times.size
        if window.observed is None:
            return Tracking({y: np.zeros(N) for y in self.tracked}, self.weights)
        seen = np.asarray(window.observed, dtype=bool)
        if seen.shape != (N, len(self.tracked)):
            raise ValueError(
                f"window.observed: expected shape {(N, len(self.tracked))} (nodes x tracked "
                f"signals), found {seen.shape}"
            )
        values = {
            y: np.where(seen[:, j], 0.0, np.nan) if seen[:, j].any() else np.zeros(N)
            for j, y in enumerate(self.tracked)
        }
        weights = {
            y: self.weights[y] if seen[:, j].any() else 0.0 for j, y in enumerate(self.tracked)
        }
        return Tracking(values, weights)

    def __call__(self, window: WindowDesign, Tstar: np.ndarray, K: np.ndarray) -> np.ndarray:
        """The information from ``window`` at the schedule ``Tstar``, ``K``.

        Parameters
        ----------
        window : WindowDesign
        Tstar, K : ndarray
            The schedule at which the information is evaluated (it enters through the
            closed loop's Jacobian).

        Returns
        -------
        ndarray, shape (n_p, n_p)
            In the order of ``gs.parameters``; singular when the window does not reach every
            schedule point.

        Raises
        ------
        ValueError
            When the data and dynamics do not determine the window's states.
        """
        from colloc.nlp.kkt import eliminate_states
        from colloc.nlp.trials import as_trials

        gs = self.gs
        problem = self._problem(window)
        law = gs.torque(window.phase, window.states[:, self.feedback], Tstar, K)
        guess: dict[Any, np.ndarray] = dict(
            zip(self.dyn.model.states, window.states.T, strict=True)
        )
        guess.update({w: (window.torques - law)[:, j] for j, w in enumerate(self.motor.values())})
        z = problem.initial_guess(guess, gs.parameter_values(Tstar, K))
        design = as_trials(problem)
        _, _, S = eliminate_states(design, z, design.nlp.gauss_newton_hessian(z))
        order = self._order.get(id(problem))
        if order is None:
            index = {name: i for i, name in enumerate(problem.layout.parameter_names)}
            order = self._order[id(problem)] = [index[str(p)] for p in gs.parameters]
        # the Gauss-Newton Hessian of sum w r^2 is twice J^T W J, the Fisher information
        return 0.5 * S[np.ix_(order, order)]


def design_bound(informations: Sequence[np.ndarray]) -> np.ndarray:
    """The covariance bound of the parameters from the windows' informations, summed.

    Parameters
    ----------
    informations : sequence of ndarray, shape (n_p, n_p)

    Returns
    -------
    ndarray, shape (n_p, n_p)

    Raises
    ------
    ValueError
        When there are none, or their sum is singular (a parameter the whole design cannot
        identify).
    """
    if not informations:
        raise ValueError("informations: expected at least one window's information")
    total = np.sum(informations, axis=0)
    try:
        return np.linalg.inv(0.5 * (total + total.T))
    except np.linalg.LinAlgError as exc:
        raise ValueError(
            "the design's information is singular: some schedule parameter is not identified "
            "by these windows"
        ) from exc


#: Nodes of the pieces the smoothed windows are cut into for the bound. Measured on 20 s of a
#: 1.15 m/s trial (3 N m): pieces of 50 nodes gave a K bound 0.8 % wider than pieces of 125
#: (a join drops one interval's dynamics) in half the time, as a piece costs in proportion to
#: its nodes times the schedule points it reaches.
PIECE_NODES = 50


def pieces(window: WindowDesign, nodes: int = PIECE_NODES) -> list[WindowDesign]:
    """``window`` cut into consecutive pieces of ``nodes`` nodes (a shorter rest dropped).

    Parameters
    ----------
    window : WindowDesign
    nodes : int
        At least 3.

    Returns
    -------
    list of WindowDesign
    """
    if nodes < 3:
        raise ValueError(f"nodes: expected at least 3 nodes per piece, found {nodes}")
    out = []
    for first in range(0, window.times.size - nodes + 1, nodes):
        rows = slice(first, first + nodes)
        out.append(
            WindowDesign(
                window.times[rows],
                window.states[rows],
                window.torques[rows],
                window.belt_speed[rows],
                window.phase[rows],
                None if window.observed is None else window.observed[rows],
            )
        )
    return out


@dataclass(frozen=True)
class BoundJob:
    """One window's share of the whole design's information: what a worker needs and
    nothing that cannot travel (the model and problem are built once per worker process).

    Attributes
    ----------
    body : (float, float)
        Body mass [kg] and height [m].
    points : int
        Schedule points ``P``.
    feedback : tuple of int
        The fed-back states' indices in the model's states.
    mask : ndarray of bool, shape (6, n_s)
        The gains' structure.
    noise : tuple of (str, float)
        Tracked column -> noise standard deviation.
    motor_noise : float
        [N m] per sample.
    window : WindowDesign
    Tstar, K : ndarray
        Where the information is evaluated.
    nodes : int
        Nodes per piece.
    lab : LabSignals, optional
        A lab's markers and plates, tracked beside ``noise``'s columns.
    scheme : type, optional
        The transcription's class (:mod:`colloc.transcription`); default the midpoint rule.
    """

    body: tuple[float, float]
    points: int
    feedback: tuple[int, ...]
    mask: np.ndarray
    noise: tuple[tuple[str, float], ...]
    motor_noise: float
    window: WindowDesign
    Tstar: np.ndarray
    K: np.ndarray
    nodes: int = PIECE_NODES
    lab: LabSignals | None = None
    scheme: type | None = None


@functools.lru_cache(maxsize=2)
def _information(
    body: tuple[float, float],
    points: int,
    feedback: tuple[int, ...],
    mask: bytes,
    shape: tuple[int, int],
    noise: tuple[tuple[str, float], ...],
    motor_noise: float,
    lab: LabSignals | None,
    scheme: type | None,
) -> ClosedLoopInformation:
    from colloc.control.gain_scheduled import GainScheduled
    from colloc.identify.gait.windows import gait_dynamics

    dyn = gait_dynamics(*body)
    structure = np.frombuffer(mask, dtype=bool).reshape(shape)
    gs = GainScheduled(
        points, [dyn.model.states[i] for i in feedback], dyn.gait.torques, structure=structure
    )
    return ClosedLoopInformation(
        dyn, gs, dict(noise), motor_noise, None if scheme is None else scheme(), lab
    )


def job_information(job: BoundJob) -> np.ndarray:
    """The information of one window's pieces, summed (run here or on a worker).

    Parameters
    ----------
    job : BoundJob

    Returns
    -------
    ndarray, shape (n_p, n_p)
        In the order of the schedule's parameters.
    """
    mask = np.ascontiguousarray(job.mask, dtype=bool)
    information = _information(
        job.body,
        job.points,
        job.feedback,
        mask.tobytes(),
        mask.shape,
        job.noise,
        job.motor_noise,
        job.lab,
        job.scheme,
    )
    n = len(information.gs.parameters)
    total = np.zeros((n, n))
    for piece in pieces(job.window, job.nodes):
        total += information(piece, job.Tstar, job.K)
    return total


def full_design_bound(
    gs: Any,
    jobs: Sequence[BoundJob],
    map_jobs: Callable[[Callable[[Any], Any], list[Any]], list[Any]] | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The whole design's bound of ``T*`` and ``K``: each window's pieces' informations,
    summed over the windows.

    Parameters
    ----------
    gs : GainScheduled
        The schedule, built as the jobs describe it.
    jobs : sequence of BoundJob
        One per window.
    map_jobs : callable, optional
        ``map_jobs(function, jobs) -> results`` in order (e.g. a Dask client's); default
        here, one after another.

    Returns
    -------
    Tstar_bound, K_bound : ndarray
        The bound's standard deviations, shaped like ``T*`` and ``K`` (zero outside the
        structure).
    count : int
        Pieces used.

    Raises
    ------
    ValueError
        When the pieces do not identify every schedule parameter.
    """
    run = map_jobs if map_jobs is not None else (lambda f, items: [f(x) for x in items])
    covariance = design_bound(run(job_information, list(jobs)))
    Tstar_bound, K_bound = gs.arrays(
        dict(zip(gs.parameters, np.sqrt(np.clip(np.diag(covariance), 0.0, None)), strict=True))
    )
    count = sum(len(pieces(job.window, job.nodes)) for job in jobs)
    return Tstar_bound, K_bound, count


def lab_signals(
    trial: Any, facts: Sequence[Mapping[str, Any]], times: Sequence[np.ndarray]
) -> tuple[LabSignals, list[np.ndarray]]:
    """The lab design the marker smoother's windows tracked, and each window's samples seen.

    Parameters
    ----------
    trial : Trial
        The lab trial (its ``markers`` and ``plates`` tables).
    facts : sequence of mapping
        Each window's marker smoother facts (:func:`colloc.identify.gait.markers.marker_smoother`'s
        second value): every marker's place in its segment (the windows' least-squares places
        are averaged), the gait2d constants it set, noise levels and plate samples per node.
    times : sequence of ndarray
        Each window's node times.

    Returns
    -------
    signals : LabSignals
    observed : list of ndarray of bool, shape (N_w, n_y)
        Per window: the markers' ``x`` and ``y``, then (when tracked) the plates' six
        channels, seen at each node.

    Raises
    ------
    ValueError
        When there are no windows, or the windows' facts disagree on the markers.
    """
    from colloc.identify.gait.markers import markers_on_nodes, plates_on_nodes

    if not facts or len(facts) != len(times):
        raise ValueError(
            f"facts, times: expected one of each per window, found {len(facts)} and {len(times)}"
        )
    first = facts[0]
    names = list(first["markers"])
    if any(list(f["markers"]) != names for f in facts):
        raise ValueError("facts: expected the same markers in every window")
    local: dict[str, tuple[float, float]] = {}
    for name in names:
        a, b = np.mean([f["markers"][name]["in_segment_m"] for f in facts], axis=0)
        local[name] = (float(a), float(b))
    noise = first["noise"]
    samples = float(np.median([f.get("plate_samples_per_node", 0.0) for f in facts]))
    shrink = 1.0 / np.sqrt(max(samples, 1.0))
    plates = samples > 0
    signals = LabSignals(
        tuple((name, str(first["markers"][name]["segment"])) for name in names),
        tuple((name, local[name]) for name in names),
        tuple((name, float(v)) for name, v in first.get("constants", {}).items()),
        float(noise["marker_m"]),
        (float(noise["force_n"]) * shrink, float(noise["moment_nm"]) * shrink) if plates else None,
    )
    observed = []
    for t in times:
        seen = markers_on_nodes(trial.tables["markers"], t)
        columns = [np.isfinite(seen[name][:, k]) for name in names for k in (0, 1)]
        if plates:
            values, _ = plates_on_nodes(trial.tables["plates"], t)
            columns += list(np.isfinite(values).T)
        observed.append(np.column_stack(columns))
    return signals, observed


__all__ = [
    "PIECE_NODES",
    "BoundJob",
    "job_information",
    "ClosedLoopInformation",
    "LabSignals",
    "WindowDesign",
    "design_bound",
    "full_design_bound",
    "lab_signals",
    "pieces",
]
