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
    """

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    belt_speed: np.ndarray
    phase: np.ndarray


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

    Raises
    ------
    ValueError
        For a motor noise or tracked noise that is not a positive number, or an unknown
        column.
    """

    def __init__(
        self,
        dyn: Any,
        gs: Any,
        noise: Mapping[str, float],
        motor_noise: float,
        scheme: Any = None,
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
        self.tracked = [by_column[c] for c in noise]
        self.weights = {by_column[c]: 1.0 / v**2 for c, v in noise.items()}
        self.motor = {T: dynamicsymbols(f"motor_noise_{name_of(T)}") for T in gait.torques}
        self.motor_noise = float(motor_noise)
        index = {x: i for i, x in enumerate(model.states)}
        self.feedback = [index[x] for x in gs.feedback]
        self._built: dict[tuple[int, float], Any] = {}
        self._order: dict[int, list[int]] = {}  # a built problem's parameters in gs's order

    def _problem(self, window: WindowDesign) -> Any:
        from colloc.nlp.objective import Tracking
        from colloc.nlp.problem import Problem
        from colloc.transcription import Midpoint

        dyn, gs, gait = self.dyn, self.gs, self.dyn.gait
        N = window.times.size
        known = {gait.belt_speed: window.belt_speed, gs.phase: window.phase}
        key = (N, round(float(np.mean(np.diff(window.times))), 9))
        problem = self._built.get(key)
        if problem is None:
            closed = dyn.model.with_outputs(self.tracked).with_disturbances(self.motor)
            # the data's values do not enter the Gauss-Newton information, only where it is
            # taken: the tracked values are zeros
            problem = Problem(
                closed.close_loop(gs),
                window.times,
                scheme=Midpoint() if self.scheme is None else self.scheme,
                known_trajectories=known,
                known_parameters=dict(dyn.constants),
                objective=Tracking({y: np.zeros(N) for y in self.tracked}, self.weights),
                process_noise=dict.fromkeys(self.motor.values(), self.motor_noise),
            )
            self._built[key] = problem
        else:
            problem.replace_data(known_trajectories=known)
        return problem

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


@functools.lru_cache(maxsize=2)
def _information(
    body: tuple[float, float],
    points: int,
    feedback: tuple[int, ...],
    mask: bytes,
    shape: tuple[int, int],
    noise: tuple[tuple[str, float], ...],
    motor_noise: float,
) -> ClosedLoopInformation:
    from colloc.control.gain_scheduled import GainScheduled
    from colloc.identify.gait.windows import gait_dynamics

    dyn = gait_dynamics(*body)
    structure = np.frombuffer(mask, dtype=bool).reshape(shape)
    gs = GainScheduled(
        points, [dyn.model.states[i] for i in feedback], dyn.gait.torques, structure=structure
    )
    return ClosedLoopInformation(dyn, gs, dict(noise), motor_noise)


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


__all__ = [
    "PIECE_NODES",
    "BoundJob",
    "job_information",
    "ClosedLoopInformation",
    "WindowDesign",
    "design_bound",
    "full_design_bound",
    "pieces",
]
