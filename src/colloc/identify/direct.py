"""Direct identification: parameters that enter the equations linearly, by least squares.

With measured states and their derivatives the residual ``F(x', x, r, p) = F0 + A theta``
is linear in the unknowns ``theta`` (feedback gains always are), so ``theta`` follows from
one linear least-squares fit over every sample. It is biased by noise in the regressors,
but it is cheap and close, which makes it the starting point that lets many-link
collocation problems converge.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sm

from colloc.model.model import Model
from colloc.model.symbols import name_of

if TYPE_CHECKING:
    from colloc.control.gain_scheduled import GainScheduled


def direct_estimate(
    model: Model,
    unknown: Sequence[sm.Symbol],
    times: np.ndarray,
    states: np.ndarray,
    state_derivatives: np.ndarray,
    known_inputs: Mapping[sm.Basic, np.ndarray] | None = None,
    known_parameters: Mapping[sm.Symbol, float] | None = None,
) -> dict[sm.Symbol, float]:
    """Least-squares estimate of parameters that enter ``model.residual`` linearly.

    Parameters
    ----------
    model : Model
    unknown : sequence of sympy.Symbol
        The parameters to estimate; the residual must be affine in them.
    times : ndarray, shape (N,)
    states, state_derivatives : ndarray, shape (N, n)
        Estimates of ``x`` and ``x'`` (e.g. smoothed measurements).
    known_inputs : mapping, optional
        Input symbol -> values at ``times`` (every input of the model).
    known_parameters : mapping, optional
        Values of every other parameter.

    Returns
    -------
    dict
        Symbol -> estimate.

    Raises
    ------
    ValueError
        When the residual is not affine in the unknowns, or data are missing or misshapen.
    """
    known_inputs = dict(known_inputs or {})
    known_parameters = dict(known_parameters or {})
    N, n = len(times), model.num_states
    problems = []
    for label, arr in (("states", states), ("state_derivatives", state_derivatives)):
        if np.shape(arr) != (N, n):
            problems.append(f"{label}: expected shape ({N}, {n}), found {np.shape(arr)}")
    missing_r = [name_of(r) for r in model.inputs if r not in known_inputs]
    if missing_r:
        problems.append(f"known_inputs: no values for inputs {missing_r}")
    missing_p = [
        name_of(p) for p in model.parameters if p not in known_parameters and p not in unknown
    ]
    if missing_p:
        problems.append(f"known_parameters: no values for {missing_p}")
    theta = list(unknown)
    F = model.residual.xreplace({p: sm.Float(v) for p, v in known_parameters.items()})
    A = F.jacobian(theta)
    nonlinear = sorted({name_of(s) for s in A.free_symbols & set(theta)})
    if nonlinear:
        problems.append(f"unknown: the residual is not affine in {nonlinear}")
    if problems:
        raise ValueError("direct_estimate: " + "; ".join(problems))
    F0 = F.xreplace(dict.fromkeys(theta, sm.Integer(0)))
    args = list(model.state_derivatives) + list(model.states) + list(model.inputs) + [model.t]
    dummies = sm.symbols(f"_a0:{len(args)}")
    swap = dict(zip(args, dummies, strict=True))
    fA = sm.lambdify(dummies, list(A.xreplace(swap)), modules="numpy", cse=True)
    f0 = sm.lambdify(dummies, list(F0.xreplace(swap)), modules="numpy", cse=True)
    values = (
        [state_derivatives[:, j] for j in range(n)]
        + [states[:, j] for j in range(n)]
        + [np.asarray(known_inputs[r], float) for r in model.inputs]
        + [np.asarray(times, float)]
    )
    rows_A = _stack(fA(*values), N, (F.shape[0], len(theta)))
    rows_0 = _stack(f0(*values), N, (F.shape[0], 1))[..., 0]
    design = rows_A.reshape(-1, len(theta))
    target = -rows_0.reshape(-1)
    used = np.any(design != 0.0, axis=1)
    solution, *_ = np.linalg.lstsq(design[used], target[used], rcond=None)
    return dict(zip(theta, map(float, solution), strict=True))


def _stack(value: list[Any], N: int, shape: tuple[int, int]) -> np.ndarray:
    # The flat list mixes arrays and constant scalars; broadcast each entry to N samples.
    out = np.empty((N, shape[0] * shape[1]))
    for e, entry in enumerate(value):
        out[:, e] = np.broadcast_to(np.asarray(entry, dtype=float), (N,))
    return out.reshape(N, *shape)


def uniform_step(times: np.ndarray, purpose: str) -> float:
    """The sampling interval of uniformly sampled ``times``.

    Raises
    ------
    ValueError
        When the steps differ (relative 1e-6), naming ``purpose``.
    """
    steps = np.diff(np.asarray(times, dtype=float))
    h = float(np.mean(steps))
    if not np.allclose(steps, h, rtol=1e-6, atol=1e-12):
        raise ValueError(f"times: expected uniform sampling for {purpose}")
    return h


def smooth_with_derivatives(
    times: np.ndarray, values: np.ndarray, window: float, order: int = 3
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Savitzky-Golay smoothing of uniformly sampled data with its first two derivatives.

    Parameters
    ----------
    times : ndarray, shape (N,)
        Uniform sample times.
    values : ndarray, shape (N,) or (N, k)
    window : float
        Window length in seconds (rounded to an odd number of samples).
    order : int
        Polynomial order.

    Returns
    -------
    value, first derivative, second derivative : ndarray
    """
    from scipy.signal import savgol_filter  # scipy.signal costs ~0.8 s to import

    h = uniform_step(times, "Savitzky-Golay smoothing")
    samples = max(order + 2, int(round(window / h)) | 1)
    if samples > len(times):
        raise ValueError(
            f"window: {window} s spans {samples} samples, more than the {len(times)} available"
        )
    kw = {"window_length": samples, "polyorder": order, "axis": 0, "delta": h}
    return (
        savgol_filter(values, deriv=0, **kw),
        savgol_filter(values, deriv=1, **kw),
        savgol_filter(values, deriv=2, **kw),
    )


@dataclass
class ScheduleFit:
    """A gain schedule fitted by least squares to measured inputs.

    Attributes
    ----------
    Tstar : ndarray, shape (P, m)
    K : ndarray, shape (P, m, n_s)
        Zero outside the controller's structure.
    residual : ndarray, shape (N, m)
        Measured minus fitted inputs.
    """

    Tstar: np.ndarray
    K: np.ndarray
    residual: np.ndarray


def fit_gain_schedule(
    controller: GainScheduled,
    phase: np.ndarray,
    feedback: np.ndarray,
    inputs: np.ndarray,
) -> ScheduleFit:
    """Direct identification of ``T(t) = T*(phi) - K(phi) s(t)`` from measured ``T`` and ``s``.

    The law is linear in ``T*`` and ``K`` at the schedule points, with the controller's own
    periodic linear interpolation in the phase, so one linear least-squares problem per input
    (its ``T*`` and allowed gains at every point) recovers a controller of this class exactly
    from exact data. Noise in ``s`` biases it (errors in the regressors), which the
    collocation identification does not suffer.

    Parameters
    ----------
    controller : GainScheduled
        Gives ``P``, the structure and the interpolation.
    phase : ndarray, shape (N,)
        Unwrapped phase in cycles at each sample.
    feedback : ndarray, shape (N, n_s)
        Measured ``s``, columns in the order of ``controller.feedback``.
    inputs : ndarray, shape (N, m)
        Measured ``T``, columns in the order of ``controller.inputs``.

    Returns
    -------
    ScheduleFit

    Raises
    ------
    ValueError
        When the arrays are misshapen or not finite, or the data cannot determine every
        parameter (phases near some schedule points not visited, or fewer samples there than
        the point has parameters): the message names the points and what they lack.
    """
    P, m, ns = controller.num_points, len(controller.inputs), len(controller.feedback)
    phase, feedback, inputs, problems = schedule_data(controller, phase, feedback, inputs)
    if problems:
        raise ValueError("fit_gain_schedule: " + "; ".join(problems))
    Tstar, K = np.zeros((P, m)), np.zeros((P, m, ns))
    residual = np.empty_like(inputs)
    for i in range(m):
        design, allowed = schedule_design(controller, phase, feedback, i)
        width = 1 + allowed.size
        check_determined(design, width, controller, i)
        theta, *_ = np.linalg.lstsq(design, inputs[:, i], rcond=None)
        theta = theta.reshape(P, width)
        Tstar[:, i] = theta[:, 0]
        K[:, i, allowed] = theta[:, 1:]
        residual[:, i] = inputs[:, i] - design @ theta.ravel()
    return ScheduleFit(Tstar, K, residual)


def schedule_data(
    controller: GainScheduled, phase: Any, feedback: Any, inputs: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """The phase, feedback and inputs of a schedule's least squares as float arrays, with every
    problem of their shapes and values (``phase (N,)``, ``feedback (N, n_s)``, ``inputs (N, m)``,
    finite)."""
    m, ns = len(controller.inputs), len(controller.feedback)
    phase, feedback, inputs = (np.asarray(a, dtype=float) for a in (phase, feedback, inputs))
    N = phase.shape[0] if phase.ndim == 1 else -1
    problems = []
    for label, arr, shape in (
        ("phase", phase, (N,)),
        ("feedback", feedback, (N, ns)),
        ("inputs", inputs, (N, m)),
    ):
        if arr.shape != shape:
            problems.append(f"{label}: expected shape {shape}, found {arr.shape}")
        elif not np.all(np.isfinite(arr)):
            problems.append(f"{label}: expected finite values, found NaN or inf")
    return phase, feedback, inputs, problems


def schedule_design(
    controller: GainScheduled,
    phase: np.ndarray,
    feedback: np.ndarray,
    i: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares design of input ``i`` of ``T = T*(phi) - K(phi) s``.

    Parameters
    ----------
    controller : GainScheduled
    phase : ndarray, shape (N,)
        Unwrapped phase in cycles.
    feedback : ndarray, shape (N, n_s)
    i : int
        The input (row of ``controller.mask``).

    Returns
    -------
    design : ndarray, shape (N, P * (1 + a))
        Columns point-major: ``T*`` then the ``a`` allowed gains of each schedule point,
        weighted by the controller's periodic linear interpolation in the phase.
    allowed : ndarray of int
        The feedback columns input ``i`` may use.
    """
    P = controller.num_points
    N = phase.shape[0]
    a, b, w = controller.schedule.bracket(phase)
    allowed = np.flatnonzero(controller.mask[i])
    width = 1 + allowed.size
    local = np.hstack([np.ones((N, 1)), -feedback[:, allowed]])
    design = np.zeros((N, P * width))
    rows = np.arange(N)
    for point, weight in ((a, 1.0 - w), (b, w)):
        design[rows[:, None], point[:, None] * width + np.arange(width)] += weight[:, None] * local
    return design, allowed


def check_determined(design: np.ndarray, width: int, controller: GainScheduled, i: int) -> None:
    """Raise ``ValueError`` naming the schedule points of input ``i`` that ``design`` (from
    :func:`schedule_design`, ``width`` columns a point) does not determine."""
    # the normal matrix is block tridiagonal in the points; a point is undetermined when its
    # block column has rank below its width (no data, or too few distinct samples nearby)
    P = controller.num_points
    lacking = []
    for p in range(P):
        block = design[:, p * width : (p + 1) * width]
        used = np.any(block != 0.0, axis=1)
        rank = np.linalg.matrix_rank(block[used]) if used.any() else 0
        if rank < width:
            lacking.append(f"point {p} (phase {p / P:.3f}): rank {rank} of {width}")
    if lacking:
        raise ValueError(
            f"fit_gain_schedule: the data do not determine the schedule of input "
            f"{name_of(controller.inputs[i])} at {len(lacking)} of {P} points "
            f"({'; '.join(lacking[:5])}{'; ...' if len(lacking) > 5 else ''}): record more "
            f"strides or use fewer points"
        )
