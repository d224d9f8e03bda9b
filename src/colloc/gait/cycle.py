"""A periodic walking cycle of the planar gait model at a given belt speed, by collocation.

The open-loop gait2d model (joint torques are free trajectories) is transcribed over one
stride with every state periodic, ``x(T) = x(0)`` (on a treadmill the hip stays in place, so
the hip's forward position is periodic too and pinned to 0 at the start). The objective
tracks Winter's normal joint angles (right leg from heel strike, the left leg half a stride
later; the same angles at every speed), keeps the trunk near upright, weakly follows Winter's
vertical ground reaction force of each foot (which keeps heel-strike impacts realistic), and
penalises joint torques:

.. math::

    J = \\frac{1}{N} \\sum_k \\Big[\\sum_j \\Big(\\frac{\\theta_{jk} - \\theta^W_{jk}}{1^\\circ}
        \\Big)^2 + w_a \\Big(\\frac{q_{a,k}}{1^\\circ}\\Big)^2
        + w_F \\sum_{s} \\Big(\\frac{F_{y,sk} - F^W_{y,sk}}{0.1\\,m g}\\Big)^2\\Big]
        + \\frac{w_T}{T} \\int_0^T \\sum_j \\Big(\\frac{T_j}{100\\,\\mathrm{N\\,m}}\\Big)^2 dt

The stiff contact makes a cold start hard, so the solve is a homotopy: a soft contact
(smaller stiffness, wider friction and smoothing scales) first, then each following stage
starts from the previous solution, ending at the model's real contact constants.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import fields
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me
from scipy.interpolate import CubicSpline

from colloc.data.records import WinterGaitCycle, read_winter_gait_cycle
from colloc.gait.walking_cycle import WalkingCycle
from colloc.model.model import Model
from colloc.models.gait2d import CONTACT_POINT_NAMES, Gait2D, derive
from colloc.models.gait2d_params import ContactParameters, Gait2DParameters, load_parameters
from colloc.nlp.objective import IntegralCost, Tracking
from colloc.nlp.problem import Problem
from colloc.transcription.backward_euler import BackwardEuler
from colloc.transcription.base import Scheme

#: Fewer nodes than this cannot resolve heel strike, foot flat and push-off of a stride.
MIN_NUM_NODES = 20
#: Environment variable naming Winter's ``Winter_normal.csv`` (overrides the default search).
WINTER_ENV = "COLLOC_WINTER_GAIT_CYCLE"
#: Default number of collocation nodes per stride.
DEFAULT_NUM_NODES = 60
#: Weight ``w_a`` of the trunk-upright term (see the module docstring).
TRUNK_WEIGHT = 0.1
#: Weight ``w_T`` of the torque term (see the module docstring).
TORQUE_WEIGHT = 100.0
#: Weight ``w_F`` of the vertical-GRF term (see the module docstring).
GRF_WEIGHT = 1.0
#: Contact constants of the soft first stages of the homotopy, softest first. Measured at
#: 60 nodes: with the middle stage the real contact converges in ~25 iterations instead of
#: ~230 straight from the softest one, to the same solution.
SOFT_CONTACT_STAGES: tuple[dict[str, float], ...] = (
    {"stiffness": 5e6, "friction_velocity": 0.1, "smoothing": 1e-3},
    {"stiffness": 2e7, "friction_velocity": 0.03, "smoothing": 3e-4},
)
_CONTACT_FIELDS = tuple(f.name for f in fields(ContactParameters))
_JOINTS = ("hip", "knee", "ankle")


@lru_cache(maxsize=1)
def _plant() -> tuple[Gait2D, Model]:
    """The derived gait model (slow to derive, so once per process)."""
    gait = derive()
    return gait, gait.to_model()


def default_winter_path() -> Path:
    """Where Winter's normal gait cycle is read from by default.

    ``$COLLOC_WINTER_GAIT_CYCLE`` if set, else the copy shipped in ``colloc/gait/reference``
    (see its SOURCE.md).
    """
    if os.environ.get(WINTER_ENV):
        return Path(os.environ[WINTER_ENV])
    return Path(__file__).resolve().parent / "reference" / "Winter_normal.csv"


def stride_duration(speed: float, reference: WinterGaitCycle) -> float:
    """Stride duration at ``speed``, scaled from the reference stride.

    Stride length and cadence both grow roughly as the square root of walking speed
    (speed = length x cadence), so the duration scales as ``(v_ref / v)^(1/2)``.
    """
    return reference.cycle_duration * float(np.sqrt(reference.walking_speed / speed))


def reference_angles(reference: WinterGaitCycle, phase: np.ndarray) -> np.ndarray:
    """Winter's joint angles ``qb .. qg`` at ``phase`` (right leg; left half a stride later).

    Returns
    -------
    ndarray, shape (len(phase), 6)
    """
    splines = []
    for joint in _JOINTS:
        y = np.asarray(getattr(reference, joint), dtype=float).copy()
        y[-1] = y[0]  # 100 % is the next heel strike; close the loop exactly
        splines.append(CubicSpline(reference.percent / 100.0, y, bc_type="periodic"))
    right = [s(np.mod(phase, 1.0)) for s in splines]
    left = [s(np.mod(phase + 0.5, 1.0)) for s in splines]
    return np.column_stack(right + left)


def _check_arguments(
    speed: Any, num_nodes: Any, duration: Any, contact_overrides: Any, params: Any
) -> None:
    problems = []
    if isinstance(speed, bool) or not isinstance(speed, int | float) or not speed > 0:
        problems.append(f"speed: expected a positive belt speed in m/s, found {speed!r}")
    elif not np.isfinite(speed):
        problems.append(f"speed: expected a finite belt speed in m/s, found {speed!r}")
    if isinstance(num_nodes, bool) or not isinstance(num_nodes, int | np.integer):
        problems.append(f"num_nodes: expected an integer, found {num_nodes!r}")
    elif num_nodes < MIN_NUM_NODES:
        problems.append(
            f"num_nodes: expected at least {MIN_NUM_NODES} nodes per stride, found {num_nodes}"
        )
    if duration is not None and not (
        isinstance(duration, int | float) and np.isfinite(duration) and duration > 0
    ):
        problems.append(f"duration: expected a positive stride duration in s, found {duration!r}")
    if params is not None and not isinstance(params, Gait2DParameters):
        problems.append(
            f"params: expected Gait2DParameters (load_parameters()), found {type(params).__name__}"
        )
    problems += _contact_problems("contact_overrides", contact_overrides)
    _raise_if_any(problems)


def _contact_problems(argument: str, overrides: Any) -> list[str]:
    if overrides is None:
        return []
    if not isinstance(overrides, Mapping):
        return [f"{argument}: expected a mapping name -> value, found {type(overrides).__name__}"]
    problems = []
    for name, value in overrides.items():
        if name not in _CONTACT_FIELDS:
            problems.append(
                f"{argument}: expected keys among {list(_CONTACT_FIELDS)}, found {name!r}"
            )
        elif isinstance(value, bool) or not (
            isinstance(value, int | float) and np.isfinite(value) and value > 0
        ):
            problems.append(f"{argument}[{name!r}]: expected a positive number, found {value!r}")
    return problems


def _raise_if_any(problems: list[str]) -> None:
    if problems:
        raise ValueError("; ".join(problems))


def _contact_values(
    gait: Gait2D, params: Gait2DParameters, overrides: Mapping[str, float]
) -> dict[sm.Symbol, float]:
    symbols = gait.contact_symbols
    return gait.constant_values(params, {getattr(symbols, k): v for k, v in overrides.items()})


def initial_guess(
    gait: Gait2D,
    params: Gait2DParameters,
    reference: WinterGaitCycle,
    times: np.ndarray,
    penetration: float = 0.015,
) -> np.ndarray:
    """States ``(N, 18)`` near a periodic walking motion.

    Joint angles are Winter's, trunk upright, hip at ``x = 0``; the hip height puts the lowest
    contact point ``penetration`` into the floor (about body weight on the cubic contact);
    speeds are periodic central differences.
    """
    num = times.size
    phase = times / times[-1]
    q = np.zeros((num, 9))
    q[:, 3:] = reference_angles(reference, phase)
    heights = gait.lambdify([gait.contact_points[n][1] for n in CONTACT_POINT_NAMES])
    p = gait.constant_array(params)
    lowest = np.array([min(heights(qk, np.zeros(9), np.zeros(6), 0.0, p)) for qk in q])
    q[:, 1] = -lowest - penetration
    h = times[1] - times[0]
    distinct = q[:-1]
    u = np.zeros_like(q)
    u[:-1] = (np.roll(distinct, -1, axis=0) - np.roll(distinct, 1, axis=0)) / (2 * h)
    u[-1] = u[0]
    return np.hstack([q, u])


def find_walking_cycle(
    speed: float = 1.2,
    num_nodes: int = DEFAULT_NUM_NODES,
    scheme: Scheme | None = None,
    params: Gait2DParameters | None = None,
    contact_overrides: Mapping[str, float] | None = None,
    duration: float | None = None,
    progress: Callable[[dict[str, float]], None] | None = None,
    cache: bool | str | os.PathLike[str] = True,
    reference: WinterGaitCycle | str | os.PathLike[str] | None = None,
    soft_stages: tuple[Mapping[str, float], ...] = SOFT_CONTACT_STAGES,
    **ipopt_options: Any,
) -> WalkingCycle:
    """Find a periodic stride of the planar gait model on a treadmill by collocation.

    Parameters
    ----------
    speed : float
        Belt speed [m/s], > 0.
    num_nodes : int
        Collocation nodes over the stride (the last repeats the first), at least
        :data:`MIN_NUM_NODES`.
    scheme : Scheme, optional
        Default ``BackwardEuler()``: it enforces the dynamics at the nodes, so the contact
        forces reported at the nodes are the ones the solution obeys. (With ``Midpoint()``
        the stiff contact forces at the nodes differ from those at the interval midpoints.)
    params : Gait2DParameters, optional
        Default ``load_parameters()`` (75 kg, 1.80 m).
    contact_overrides : mapping, optional
        :class:`ContactParameters` field name -> value replacing the model's contact constant
        in the final stage (e.g. ``{"stiffness": 1e6}``).
    duration : float, optional
        Stride duration [s]; default :func:`stride_duration` of ``speed``.
    progress : callable, optional
        Called after each IPOPT iteration (see :meth:`Problem.solve`).
    cache : bool or path
        The build cache of :class:`Problem`.
    reference : WinterGaitCycle or path, optional
        The gait to track; default read from :func:`default_winter_path`.
    soft_stages : tuple of mappings
        Contact overrides of the homotopy's soft stages, solved in order before the final
        stage; ``()`` solves the final contact from the initial guess directly.
    **ipopt_options
        Passed to IPOPT (e.g. ``max_iter``, ``tol``).

    Returns
    -------
    WalkingCycle

    Raises
    ------
    ValueError
        Listing every bad argument.
    FileNotFoundError
        If the reference gait file is missing.
    RuntimeError
        If IPOPT does not converge in a stage (the message carries its status and hint).
    """
    _check_arguments(speed, num_nodes, duration, contact_overrides, params)
    soft_stages = tuple(soft_stages or ())
    _raise_if_any(
        [m for i, st in enumerate(soft_stages) for m in _contact_problems(f"soft_stages[{i}]", st)]
    )
    scheme = BackwardEuler() if scheme is None else scheme
    params = load_parameters() if params is None else params
    if not isinstance(reference, WinterGaitCycle):
        path = default_winter_path() if reference is None else Path(reference)
        if not path.is_file():
            raise FileNotFoundError(
                f"reference: expected Winter's Winter_normal.csv, found no file at {path}; pass "
                f"reference= (a path or WinterGaitCycle) or set ${WINTER_ENV}"
            )
        reference = read_winter_gait_cycle(path)
    gait, model = _plant()
    model = model.with_outputs({**model.outputs, **_grf_outputs(gait)})
    T = stride_duration(speed, reference) if duration is None else float(duration)
    times = np.linspace(0.0, T, num_nodes)
    phase = times / T
    objective = _objective(gait, params, reference, phase, num_nodes, T)
    q, r = gait.coordinates, gait.torques
    periodic = [x.func(T) - x.func(0.0) for x in (*model.states, *r)] + [q[0].func(0.0)]
    final = dict(contact_overrides or {})
    stages: list[dict[str, Any]] = []
    options = {"print_level": 0, "max_iter": 1000} | ipopt_options
    z = None
    for overrides in (*soft_stages, final):
        problem = Problem(
            model,
            times,
            scheme=scheme,
            known_trajectories={gait.belt_speed: np.full(num_nodes, float(speed))},
            known_parameters=_contact_values(gait, params, overrides),
            objective=objective,
            instance_constraints=periodic,
            cache=cache if isinstance(cache, bool) else str(cache),
        )
        if z is None:
            x0 = initial_guess(gait, params, reference, times)
            z = problem.initial_guess({x: x0[:, j] for j, x in enumerate(model.states)})
        solution = problem.solve(z, progress=progress, **options)
        stages.append(
            {"contact": dict(overrides)}
            | {k: solution.stats[k] for k in ("status", "iterations", "solve_time", "build_time")}
        )
        if not solution.success:
            raise RuntimeError(
                f"walking cycle: IPOPT stopped with {solution.status.name} in the stage with "
                f"contact {dict(overrides)} after {solution.stats['iterations']} iterations; "
                "try more nodes, an extra soft stage (soft_stages=) or a larger max_iter "
                f"({solution.stats['hint']})"
            )
        z = solution.z
    return _cycle(gait, params, problem, solution, reference, float(speed), T, stages)


def _grf_outputs(gait: Gait2D) -> dict[sm.Basic, sm.Expr]:
    """Total vertical floor force on each foot, as model outputs."""
    f = gait.contact_forces
    return {
        me.dynamicsymbols(f"Fy_{side}"): f[f"{side}_heel"][1] + f[f"{side}_toe"][1]
        for side in ("right", "left")
    }


def _objective(
    gait: Gait2D,
    params: Gait2DParameters,
    reference: WinterGaitCycle,
    phase: np.ndarray,
    num_nodes: int,
    duration: float,
) -> list[Any]:
    q = gait.coordinates
    angles = reference_angles(reference, phase)
    w_angle = 1.0 / (num_nodes * np.deg2rad(1.0) ** 2)
    measured = {q[3 + j]: angles[:, j] for j in range(6)} | {q[2]: np.zeros(num_nodes)}
    weights = dict.fromkeys(measured, w_angle) | {q[2]: TRUNK_WEIGHT * w_angle}
    weight = params.total_mass * params.gravity

    def grf(ph: np.ndarray) -> np.ndarray:  # linear: a spline would ring at heel strike
        return np.interp(ph, reference.percent / 100.0, reference.vertical_grf) * params.body_mass

    Fy_right, Fy_left = _grf_outputs(gait)
    forces = {Fy_right: grf(phase), Fy_left: grf(np.mod(phase + 0.5, 1.0))}
    w_force = GRF_WEIGHT / (num_nodes * (0.1 * weight) ** 2)
    effort = sum((Ti / 100.0) ** 2 for Ti in gait.torques) * (TORQUE_WEIGHT / duration)
    return [Tracking(measured, weights), Tracking(forces, w_force), IntegralCost(effort)]


def _cycle(
    gait: Gait2D,
    params: Gait2DParameters,
    problem: Problem,
    solution: Any,
    reference: WinterGaitCycle,
    speed: float,
    duration: float,
    stages: list[dict[str, Any]],
) -> WalkingCycle:
    states = np.column_stack([solution.trajectories[x] for x in problem.model.states])
    torques = np.column_stack([solution.trajectories[r] for r in gait.torques])
    forces_fn = gait.lambdify([gait.contact_forces[n] for n in CONTACT_POINT_NAMES])
    p = np.array([problem.known_parameters[c] for c in gait.constants])
    forces = np.array(
        [
            np.ravel(forces_fn(x[:9], x[9:], tq, speed, p))
            for x, tq in zip(states, torques, strict=True)
        ]
    )
    error = np.rad2deg(states[:, 3:9] - reference_angles(reference, solution.times / duration))
    stats = {k: v for k, v in solution.stats.items() if k != "ipopt_log"}
    cycle = WalkingCycle(solution.times, states, torques, forces, speed, duration, stats)
    weight = params.total_mass * params.gravity
    stats |= {
        "num_nodes": int(solution.times.size),
        "stages": stages,
        "rms_angle_error_deg": float(np.sqrt(np.mean(error[:-1] ** 2))),
        "rms_angle_error_by_joint_deg": np.sqrt(np.mean(error[:-1] ** 2, axis=0)).tolist(),
        "peak_vertical_grf_bw": float(cycle.vertical_grf.max() / weight),
    }
    return cycle
