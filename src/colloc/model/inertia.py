"""A mechanical model's mass matrix, checked with the parameter values a user gives.

Kane's and Lagrange's dynamic equations are ``M(q) u' = f``, with ``M`` symmetric and
positive definite for any physical masses and inertias. A known mass of -1 makes ``M``
indefinite; the collocation problem still solves, to a motion no physical system makes and
gains that fit it (k3 = -2845 on the 1-link pendulum). So with the known values substituted,
``M`` is evaluated at the zero state and at a few seeded random states, and a negative
eigenvalue is an error that names the values.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import lru_cache

import numpy as np
import sympy as sm

from colloc.model.symbols import name_of

#: Random states (besides zero) at which the mass matrix is evaluated.
CHECK_STATES = 2

#: Relative tolerance of the symmetry and sign checks.
TOLERANCE = 1e-9


def inertia_problems(model: object, known: Mapping[sm.Symbol, float], seed: int = 0) -> list[str]:
    """Why the mass matrix of ``model`` is not positive definite with the ``known`` values.

    Parameters
    ----------
    model : colloc.Model
        Its ``inertia`` is the mass matrix; a model without one (from plain equations) has
        nothing to check.
    known : mapping
        Parameter -> value.
    seed : int, optional
        Seed of the random states.

    Returns
    -------
    list of str
        Empty when the check passes or cannot be made (``M`` depends on unknown
        parameters or inputs, or is not symmetric, as with nonholonomic constraints).
    """
    inertia = getattr(model, "inertia", None)
    if inertia is None or inertia.shape[0] != inertia.shape[1]:
        return []
    states, t = model.states, model.t  # type: ignore[attr-defined]
    constants = tuple(sorted(inertia.free_symbols - set(states) - {t}, key=str))
    if any(p not in known for p in constants):
        return []  # depends on unknown parameters or inputs: nothing to say here
    compiled = _compiled(inertia, tuple(states), t, constants)
    if compiled is None:
        return []
    values = [float(known[p]) for p in constants]
    rng = np.random.default_rng(seed)
    points = [np.zeros(len(states))] + [rng.normal(size=len(states)) for _ in range(CHECK_STATES)]
    for k, point in enumerate(points):
        matrix = np.asarray(compiled(point, 0.0, values), dtype=float)
        scale = max(float(np.max(np.abs(matrix))), 1e-300)
        if not np.all(np.isfinite(matrix)) or np.max(np.abs(matrix - matrix.T)) > TOLERANCE * scale:
            return []  # not a symmetric mass matrix: not this check's business
        smallest = float(np.linalg.eigvalsh(matrix)[0])
        if smallest < -TOLERANCE * scale:
            where = "the zero state" if k == 0 else f"a random state (seed {seed})"
            used = sorted((name_of(p), float(known[p])) for p in constants)
            shown = ", ".join(f"{n}={v:g}" for n, v in used) or "none"
            return [
                "known_parameters: the mass matrix of the dynamic equations is not positive "
                f"definite with these values (smallest eigenvalue {smallest:.3g} at {where}); "
                f"no physical body has that: is a mass or an inertia negative? (values in it: "
                f"{shown})"
            ]
    return []


@lru_cache(maxsize=32)
def _compiled(
    inertia: sm.ImmutableMatrix,
    states: tuple[sm.Basic, ...],
    t: sm.Symbol,
    constants: tuple[sm.Symbol, ...],
) -> Callable[..., object] | None:
    """``M(x, t, p)`` as a NumPy function, built once per model (0.4 s for gait2d)."""
    symbols = [sm.Dummy(f"x{i}") for i in range(len(states))]
    mass = inertia.xreplace(dict(zip(states, symbols, strict=True)))
    if mass.free_symbols - set(symbols) - {t} - set(constants):
        return None  # holds inputs (or derivatives): not a plain M(q)
    return sm.lambdify([symbols, t, list(constants)], mass, modules="numpy")  # type: ignore[no-any-return]
