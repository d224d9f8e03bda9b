"""A gait controller estimate, and how far it is from the truth a synthetic trial records."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import JOINT_ANGLE_COLUMNS, JOINT_RATE_COLUMNS, TORQUE_COLUMNS
from colloc.identify.gait.read import (
    GaitData,
)

#: The controller structures' names in :class:`GainScheduled`.
JOINT_NAMES = tuple(c.removesuffix("_torque") for c in TORQUE_COLUMNS)


@dataclass
class ControllerEstimate:
    """One controller ``T*``, ``K`` with optional standard errors and the square roots of the
    Cramer-Rao bound's diagonal (the best standard deviations the design allows): the
    states-known bound (``*_bound``) and the whole design's (``*_bound_full``, states
    unknown)."""

    Tstar: np.ndarray
    K: np.ndarray
    Tstar_se: np.ndarray | None = None
    K_se: np.ndarray | None = None
    Tstar_bound: np.ndarray | None = None
    K_bound: np.ndarray | None = None
    Tstar_bound_full: np.ndarray | None = None
    K_bound_full: np.ndarray | None = None


def true_controller(
    data: GaitData, gs: GainScheduled, notes: list[str]
) -> ControllerEstimate | None:
    """The trial's true controller (``data.recorded``) when it lies in the identified class."""
    recorded = data.recorded
    if recorded is None or not {"Tstar", "K", "mask"} <= set(recorded):
        return None
    Tstar = np.asarray(recorded["Tstar"], dtype=float)
    K = np.asarray(recorded["K"], dtype=float)
    names = list(recorded.get("feedback", JOINT_ANGLE_COLUMNS + JOINT_RATE_COLUMNS))
    if Tstar.shape[0] != data.points or names != data.feedback:
        notes.append(
            f"the trial's controller (P = {Tstar.shape[0]}, feedback {names}) is not of the "
            f"identified class (P = {data.points}, feedback {data.feedback}): no errors "
            "against the truth"
        )
        return None
    if np.any(K[:, ~gs.mask] != 0):
        notes.append(
            "the trial's controller has gains outside the identified structure; its errors "
            "count those gains as missed"
        )
    return ControllerEstimate(Tstar, K)


def mean_signals_by_phase(gs: GainScheduled, phase: np.ndarray, signals: np.ndarray) -> np.ndarray:
    """The fed-back signals averaged per schedule point: ``s_mean(phi_p)``, shape (P, n_s).

    Each sample counts towards the two points around its phase with the schedule's own
    linear weights (the hat functions the controller interpolates with), so ``s_mean`` is
    the mean gait cycle as the schedule sees it.

    Parameters
    ----------
    gs : GainScheduled
    phase : ndarray, shape (N,)
        Unwrapped phase of each sample.
    signals : ndarray, shape (N, n_s)

    Returns
    -------
    ndarray, shape (P, n_s)
        NaN rows at points no sample reaches.
    """
    a, b, w = gs.schedule.bracket(np.asarray(phase, float))
    P = gs.num_points
    weight = np.bincount(a, 1.0 - w, P) + np.bincount(b, w, P)
    total = np.zeros((P, signals.shape[1]))
    np.add.at(total, a, (1.0 - w)[:, None] * signals)
    np.add.at(total, b, w[:, None] * signals)
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / weight[:, None]


def mean_cycle_torque(estimate: ControllerEstimate, mean_signals: np.ndarray) -> np.ndarray:
    """``T0(phi_p) = T*(phi_p) - K(phi_p) s_mean(phi_p)``: the torque the controller applies
    on the mean gait cycle, the joint-moment profile a biomechanist reads (``T*`` alone is
    the intercept on absolute signals, often thousands of N m), shape (P, 6)."""
    return estimate.Tstar - np.einsum("pij,pj->pi", estimate.K, mean_signals)


def estimate_metrics(
    collocation: ControllerEstimate,
    direct: ControllerEstimate,
    truth: ControllerEstimate | None,
    mask: np.ndarray,
) -> dict[str, float | None]:
    out: dict[str, float | None] = dict.fromkeys(
        (
            "K_relative_error",
            "Tstar_relative_error",
            "direct_K_relative_error",
            "direct_Tstar_relative_error",
            "fraction_within_3se",
            "K_relative_bound",
            "Tstar_relative_bound",
            "K_relative_bound_states_known",
            "Tstar_relative_bound_states_known",
            "K_relative_bound_full_design",
            "Tstar_relative_bound_full_design",
        )
    )
    from colloc.identify.gait.controller_fit import relative_spread

    # relative to the truth when there is one, else to the estimate
    reference = truth or collocation
    for suffix, Tb, Kb in (
        ("_states_known", collocation.Tstar_bound, collocation.K_bound),
        ("_full_design", collocation.Tstar_bound_full, collocation.K_bound_full),
    ):
        if Kb is not None and Tb is not None:
            out[f"K_relative_bound{suffix}"] = relative_spread(Kb, reference.K)
            out[f"Tstar_relative_bound{suffix}"] = relative_spread(Tb, reference.Tstar)
    out["K_relative_bound"] = out["K_relative_bound_states_known"]
    out["Tstar_relative_bound"] = out["Tstar_relative_bound_states_known"]
    if truth is None:
        return out
    for prefix, est in (("", collocation), ("direct_", direct)):
        out[f"{prefix}K_relative_error"] = _relative(est.K, truth.K)
        out[f"{prefix}Tstar_relative_error"] = _relative(est.Tstar, truth.Tstar)
    if collocation.K_se is not None and collocation.Tstar_se is not None:
        error = np.r_[
            (collocation.Tstar - truth.Tstar).ravel(), (collocation.K - truth.K)[:, mask].ravel()
        ]
        se = np.r_[collocation.Tstar_se.ravel(), collocation.K_se[:, mask].ravel()]
        out["fraction_within_3se"] = float(np.mean(np.abs(error) <= 3.0 * se))
    return out


def _relative(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(np.linalg.norm(estimate - truth) / np.linalg.norm(truth))
