"""The stride the continuous model actually walks: a collocation cycle settled by simulation.

A walking cycle found by collocation satisfies the discretised dynamics, not the continuous
ones: replayed open loop with its own torques, the 60-node backward-Euler cycle drifts by
0.016 rad within 20 ms and by 1 rad within a third of a stride (the contact is stiff, with
eigenvalues up to 2.8e4 1/s, and backward Euler damps what it cannot resolve). A controller
linearised along such a cycle is linearised along states the model never visits.

:func:`settle_cycle` closes the loop with a stabilising controller designed on the
collocation cycle, walks on a constant belt until the strides repeat, and returns the last
stride as a new :class:`~colloc.gait.cycle.WalkingCycle`: the states the integrator produced
and the torques the controller applied. That is an exact periodic solution of the
continuous model (to the integrator's tolerance) with those torques, so a controller
designed along it has ``T = T*`` and ``s = s*`` on the orbit itself.

The settled stride starts ``phi_0`` of a stride before a right heel strike, where
``phi_0`` is the strike phase of the collocation cycle (see
:func:`colloc.gait.strikes.strike_phase`), so that the new cycle's ``phi = 0`` sits at
the same place in the gait as the old one's; its duration is the settled stride's.
The hip's forward position ``qax`` is reported relative to the start. No force depends on
it, so only a controller that feeds it back (``feedback`` including index 0) makes it repeat;
its drift per stride is in ``stats["hip_drift_per_stride"]`` (measured on the test cycle:
1.3 mm with it fed back, 8.5 mm without).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline

from colloc.gait.closed_loop import simulate_walking
from colloc.gait.orbit import GaitDynamics
from colloc.gait.strikes import strike_phase
from colloc.gait.walking_cycle import WalkingCycle

#: Strides walked before the last one is taken (measured on the default 1.2 m/s cycle: the
#: start states of consecutive strides still differ by 6e-4 after 11 strides).
DEFAULT_SETTLE_STRIDES = 15
#: Sample rate [Hz] of the settling simulation and of the settled cycle's nodes.
DEFAULT_SETTLE_RATE = 1000.0
#: Largest accepted change between the last two strides: state at the start (all but
#: ``qax``, SI units: 1e-3 rad is 0.06 deg) and stride duration [s].
DEFAULT_SETTLE_TOLERANCE = 1e-3


class CycleNotSettledError(RuntimeError):
    """The closed loop did not settle onto a repeating stride."""


class WalkerFellError(CycleNotSettledError):
    """The closed loop fell on the constant belt (rather than walking strides that still
    differ)."""


def settle_cycle(
    cycle: WalkingCycle,
    Tstar: np.ndarray,
    K: np.ndarray,
    feedback: np.ndarray,
    *,
    dynamics: GaitDynamics | None = None,
    num_strides: int = DEFAULT_SETTLE_STRIDES,
    sample_rate: float = DEFAULT_SETTLE_RATE,
    tol: float = DEFAULT_SETTLE_TOLERANCE,
) -> WalkingCycle:
    """Walk the closed loop on a constant belt until the strides repeat; return the last one.

    Parameters
    ----------
    cycle : WalkingCycle
        The cycle the controller was designed on (belt speed, start state, phase law).
    Tstar : ndarray, shape (P, 6)
    K : ndarray, shape (P, 6, n_s)
        A stabilising controller for ``cycle`` (e.g. full-state
        :func:`colloc.gait.design.design_controller`).
    feedback : ndarray of int
        Indices of the fed-back states, as given to the design.
    dynamics : GaitDynamics, optional
    num_strides : int
        Strides to walk (>= 3); the last complete one is returned.
    sample_rate : float
        [Hz] of the simulation and of the returned cycle's nodes.
    tol : float
        Largest accepted difference between the last two strides (start state without
        ``qax``, and duration).

    Returns
    -------
    WalkingCycle
        ``stats``: ``source``, ``settle_residual`` (state), ``settle_duration_change``,
        ``hip_drift_per_stride``, ``num_strides``, ``wall_time``, ``stride_durations``.

    Raises
    ------
    ValueError
        On unusable ``num_strides``, ``sample_rate`` or ``tol``.
    CycleNotSettledError
        If the walker fell, fewer than three right heel strikes were detected, or the last
        two strides differ by more than ``tol``.
    """
    problems = []
    if isinstance(num_strides, bool) or not isinstance(num_strides, int) or num_strides < 3:
        problems.append(f"num_strides: expected an integer >= 3, found {num_strides!r}")
    for name, value in (("sample_rate", sample_rate), ("tol", tol)):
        if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
            problems.append(f"{name}: expected a positive finite number, found {value!r}")
    if problems:
        raise ValueError("settle_cycle: " + "; ".join(problems))
    dyn = dynamics or GaitDynamics.build()
    duration = (num_strides + 0.5) * float(cycle.duration)
    record = simulate_walking(
        cycle,
        Tstar,
        K,
        duration,
        None,
        dynamics=dyn,
        sample_rate=sample_rate,
        feedback=np.asarray(feedback, dtype=int),
    )
    strikes = record.right_heel_strikes
    if record.fell or strikes.size < 3:
        raise WalkerFellError(
            f"settle_cycle: the closed loop did not walk {num_strides} strides on a constant "
            f"belt ({record.message}; {strikes.size} right heel strikes); the controller does "
            "not stabilise the cycle"
        )
    phi0 = strike_phase(cycle)
    spline = CubicSpline(record.times, record.states, axis=0)
    # The last two complete strides, each from phi0 of a stride before its right heel strike.
    starts = strikes[-3:] - phi0 * float(cycle.duration)
    periods = np.diff(strikes[-3:])
    second, third = spline(starts[1:])
    residual = float(np.max(np.abs(third[1:] - second[1:])))
    change = float(abs(periods[1] - periods[0]))
    if residual > tol or change > tol:
        raise CycleNotSettledError(
            f"settle_cycle: the last two strides still differ after {strikes.size} strides "
            f"(start state by {residual:.3g}, duration by {change:.3g} s; tolerance {tol:.3g}); "
            "walk more strides (num_strides=) or use a more strongly stabilising controller"
        )
    period = float(periods[1])
    count = int(round(period * sample_rate)) + 1
    times = np.linspace(0.0, period, count)
    states = spline(starts[1] + times)
    drift = float(states[-1, 0] - states[0, 0])
    states[:, 0] -= states[0, 0]
    torques = np.column_stack(
        [np.interp(starts[1] + times, record.times, record.torques[:, j]) for j in range(6)]
    )
    belt = float(cycle.belt_speed)
    forces = np.asarray(dyn.contact_forces.map(count)(states.T, belt)).T
    stats: dict[str, Any] = {
        "source": "closed-loop simulation settled on a constant belt",
        "settle_residual": residual,
        "settle_duration_change": change,
        "hip_drift_per_stride": drift,
        "num_strides": int(strikes.size),
        "wall_time": float(record.stats["wall_time"]),
        "stride_durations": np.diff(strikes).tolist(),
    }
    return WalkingCycle(
        times=times,
        states=states,
        torques=torques,
        contact_forces=forces,
        belt_speed=belt,
        duration=period,
        stats=stats,
    )


__all__ = [
    "DEFAULT_SETTLE_RATE",
    "DEFAULT_SETTLE_STRIDES",
    "DEFAULT_SETTLE_TOLERANCE",
    "CycleNotSettledError",
    "WalkerFellError",
    "settle_cycle",
]
