"""What the gait smoother reports: each stage, its failure, and the smoothed record."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from colloc.transcription.base import Scheme


@dataclass(frozen=True)
class SmootherStage:
    """What one stage of the smoother did.

    Attributes
    ----------
    name : str
        ``start``, ``backward-euler``, the second-order scheme's name (``midpoint``,
        ``trapezoidal``) or ``continuation``.
    scheme : str
        The collocation scheme's class name.
    friction_velocity : float
        The contact's slip scale in this stage [m/s].
    status : str
        IPOPT's status (``Consistent`` for the start).
    success : bool
    iterations : int
    seconds : float
    objective, max_defect : float
        At the stage's end.
    """

    name: str
    scheme: str
    friction_velocity: float
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    max_defect: float

    def describe(self) -> str:
        """One line for progress reports and notes."""
        return (
            f"{self.name} ({self.scheme}, v_s = {self.friction_velocity:g} m/s): "
            f"{self.status}, {self.iterations} iterations, {self.seconds:.1f} s, "
            f"max defect {self.max_defect:.1e}"
        )


class SmootherError(RuntimeError):
    """A smoother stage did not converge; the message names it and the stages before it."""

    def __init__(self, message: str, stages: Sequence[SmootherStage]) -> None:
        super().__init__(message)
        self.stages = tuple(stages)


@dataclass
class SmoothedGait:
    """The smoother's result on the grid of the measurements.

    Attributes
    ----------
    times : ndarray, shape (N,)
    states : ndarray, shape (N, 18)
        ``[q, u]`` in the order of :data:`colloc.gait.metadata.STATE_SIGNAL_NAMES`.
    torques : ndarray, shape (N, 6)
        Joint torques, in the order of :data:`colloc.data.columns.TORQUE_COLUMNS`.
    residuals : ndarray, shape (N, 3)
        Residual forces on the trunk's x [N], y [N] and angle [N m].
    stages : list of SmootherStage
    problem : Problem or None
        The last stage's problem (midpoint at the model's contact); None in a copy sent to
        another process (a CasADi problem does not travel; everything else does).
    z : ndarray
        Its free vector at the solution.
    notes : list of str
        Anything the caller should know about the result.
    scheme : Scheme or None
        The last stage's scheme.
    size : dict
        The last stage's problem's size (:attr:`colloc.Problem.size`).
    seconds : float
        Wall time of :meth:`GaitSmoother.run`, the problems' builds included (the stages'
        ``seconds`` count their solves only).
    process : str
        ``host:pid`` of the process that ran it (which worker, when windows are spread).
    tracking : dict
        What the smoother tracked and with which noise levels (the marker smoother's
        markers, their places in their segments, the plates).
    inputs_in_pairs : bool
        The node torques and residual forces are determined only in pairs of neighbouring
        nodes (the marker smoother under the trapezoidal rule): they alternate node to node,
        and :meth:`node_mean_inputs` gives them without that mode.
    parameters : dict
        The output parameters estimated with the motion (name -> value), e.g. the markers'
        places in their segments; empty when none were.
    parameter_sd : dict
        Their posterior standard deviations (name -> value); empty when none were estimated
        or the bound could not be computed (the notes say why).
    """

    times: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    residuals: np.ndarray
    stages: list[SmootherStage]
    problem: Any
    z: np.ndarray
    notes: list[str] = field(default_factory=list)
    scheme: Scheme | None = None
    size: dict[str, int] = field(default_factory=dict)
    seconds: float = float("nan")
    process: str = ""
    tracking: dict[str, Any] = field(default_factory=dict)
    inputs_in_pairs: bool = False
    parameters: dict[str, float] = field(default_factory=dict)
    parameter_sd: dict[str, float] = field(default_factory=dict)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["problem"] = None  # CasADi functions do not pickle
        return state

    def _last_scheme(self) -> Scheme:
        """The last stage's scheme (a result made before ``scheme`` was kept reads its
        problem's)."""
        return self.scheme if self.scheme is not None else self.problem.scheme

    def node_mean_inputs(self) -> tuple[np.ndarray, np.ndarray]:
        """Torques and residual forces as a lab reads them: each node's the mean of its two
        intervals' (:func:`node_means`) when they are determined in pairs only
        (:attr:`inputs_in_pairs`), else the node values. The identification regresses the
        node values themselves: with the means, whose errors are correlated from node to
        node, the bound from the residual came out below the error on a 60 s lab export (K
        91 % from the truth against a bound of 36 %, 85 % within 3 SE; with the node values
        106 % against 68 %, 92 %)."""
        if not self.inputs_in_pairs or self.torques.shape[0] < 2:
            return self.torques, self.residuals
        return node_means(self.torques), node_means(self.residuals)

    def at_intervals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times, states and torques at the interval midpoints (averages of neighbouring
        nodes, which cancel the midpoint rule's odd-even mode in the node rates)."""
        mid = 0.5 * (self.times[1:] + self.times[:-1])
        return (
            mid,
            0.5 * (self.states[1:] + self.states[:-1]),
            0.5 * (self.torques[1:] + self.torques[:-1]),
        )

    def at_dynamics(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times, states and torques where the last stage's scheme holds the dynamics: the
        nodes for a scheme whose nodes satisfy them (trapezoidal, Hermite-Simpson, Radau IIA),
        else the interval midpoints (:meth:`at_intervals`; the midpoint rule)."""
        if self._last_scheme().dynamics_at_nodes:
            return self.times, self.states, self.torques
        return self.at_intervals()

    def instrument_states(self) -> np.ndarray:
        """The node states for instruments: each speed replaced by its mean over the interval
        that ends at the node where the scheme holds the dynamics between nodes.

        Under the midpoint rule only those means are tied to the positions
        (``(u_(k-1) + u_k) / 2 = (q_k - q_(k-1)) / h``); the node speeds also carry the
        rule's odd-even mode, which costs the light foot almost no torque and so reaches
        0.3-0.6 rad/s in the ankle rates. A node speed lagged one or two samples shares that
        mode with the node speed it instruments; the interval mean does not (docs/gait.md,
        the 8-minute trial). The first node keeps its own speeds.

        Returns
        -------
        ndarray, shape (N, 18)
        """
        out = self.states.copy()
        if self._last_scheme().dynamics_at_nodes or out.shape[0] < 2:
            return out
        speeds = slice(out.shape[1] // 2, None)
        out[1:, speeds] = 0.5 * (self.states[1:, speeds] + self.states[:-1, speeds])
        return out


def node_means(values: np.ndarray) -> np.ndarray:
    """Each node's value as the mean of the two intervals' around it.

    ``(v_(k-1) + 2 v_k + v_(k+1)) / 4`` inside, the one interval's mean ``(v_0 + v_1) / 2``
    at each end. This removes the odd-even mode exactly (a value alternating about its mean
    gives the mean) and keeps a straight line inside; a signal at frequency ``f`` keeps
    ``cos(pi f h)^2`` of its amplitude (98 % at 5 Hz, 90 % at 10 Hz with ``h`` = 0.01 s).

    Parameters
    ----------
    values : ndarray, shape (N, k)
        At the nodes, N >= 2.

    Returns
    -------
    ndarray, shape (N, k)
    """
    v = np.asarray(values, dtype=float)
    if v.ndim != 2 or v.shape[0] < 2:
        raise ValueError(f"values: expected shape (N, k) with N >= 2, found {v.shape}")
    pairs = 0.5 * (v[1:] + v[:-1])
    out = np.empty_like(v)
    out[0], out[-1] = pairs[0], pairs[-1]
    out[1:-1] = 0.5 * (pairs[1:] + pairs[:-1])
    return out
