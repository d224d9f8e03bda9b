"""The gain schedule from smoothed signals, with stride-sandwich errors and its bound.

Given the dynamically consistent smoother's states and torques
(:mod:`colloc.identify.gait.smoother`), ``T = T*(phi) - K(phi) s + e`` is linear in the schedule's values, so each
torque's ``T*`` and allowed gains come from one least squares. The signals are read where the
midpoint rule holds the dynamics, the interval midpoints: averages of neighbouring nodes cancel
the rule's odd-even mode, which leaves the smoothed node rates 3-50 deg/s from the truth on the
measured trials (``docs/gait.md``).

In a closed loop the fed-back state at a sample has already felt the motor noise of that
sample: the simulator's noise is linear between samples, a real one is band-limited, and the
ankle and foot answer a torque within milliseconds. The regressors then carry part of the
noise and the least squares is biased. Measured on exact states of a 120 s trial with 3 N m
motor noise: the true law leaves a white 3.0 N m residual, the least squares 1.6-1.8 N m at
the ankles (it fits the noise through the ankle rates), and K is 52 % off against the 20 %
its white-noise covariance predicts. Two-stage least squares with the states one and two
samples earlier as instruments (they precede the sample's noise) gives 21 %
(``instrument_lags``).

Standard errors are the sandwich over strides: the torque residuals are correlated within a
stride (the smoother's errors, the schedule's interpolation), independent between strides.
The bound is the Cramer-Rao bound of the same least squares with the fed-back states known
exactly and the torque equation's noise (measurement and motor noise) known: no estimator of
this design can do better, so it is a lower bound for the collocation design too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from colloc.control.gain_scheduled import GainScheduled
from colloc.identify.direct import check_determined, schedule_data, schedule_design


@dataclass
class ScheduleEstimate:
    """A gain schedule with standard errors and the bound of its design.

    Attributes
    ----------
    Tstar : ndarray, shape (P, m)
    K : ndarray, shape (P, m, n_s)
        Zero outside the controller's structure.
    Tstar_se, K_se : ndarray
        Sandwich standard errors over the blocks (zero outside the structure).
    Tstar_bound, K_bound : ndarray
        Square roots of the Cramer-Rao bound's diagonal (zero outside the structure).
    residual_std : ndarray, shape (m,)
        Root mean square of each torque's residual.
    noise_std : ndarray, shape (m,)
        The torque equation's noise used for the bound.
    blocks : int
        Number of blocks (strides) of the sandwich.
    method : str
        ``"two-stage least squares"`` or ``"least squares"`` (asked for, or because the
        samples were too few for the instruments: see ``reason``).
    reason : str
        Why the method is the one used.
    """

    Tstar: np.ndarray
    K: np.ndarray
    Tstar_se: np.ndarray
    K_se: np.ndarray
    Tstar_bound: np.ndarray
    K_bound: np.ndarray
    residual_std: np.ndarray
    noise_std: np.ndarray
    blocks: int
    method: str = "least squares"
    reason: str = "asked for"


#: Fewest samples per parameter of a torque's schedule for the instruments to pay: measured on
#: the 120 s motor-noise trial's smoothed states, K error least squares / two-stage at 3.9
#: samples a parameter 98 / 109 %, at 7.9 56 / 46 %, at 15.8 53 / 36 %, at 31 53 / 30 %.
MIN_SAMPLES_PER_PARAMETER = 6.0


def fit_schedule_with_errors(
    controller: GainScheduled,
    phase: np.ndarray,
    feedback: np.ndarray,
    inputs: np.ndarray,
    blocks: np.ndarray,
    noise_std: np.ndarray | None = None,
    instrument_lags: tuple[int, ...] = (),
    segments: np.ndarray | None = None,
    instrument_feedback: np.ndarray | None = None,
) -> ScheduleEstimate:
    """Least squares of ``T = T*(phi) - K(phi) s`` with sandwich errors and the bound.

    Parameters
    ----------
    controller : GainScheduled
    phase : ndarray, shape (N,)
        Unwrapped phase in cycles.
    feedback : ndarray, shape (N, n_s)
        ``s`` in the order of ``controller.feedback``.
    inputs : ndarray, shape (N, m)
        ``T`` in the order of ``controller.inputs``.
    blocks : ndarray of int, shape (N,)
        The block (stride) of each sample; the sandwich sums each block's score.
    noise_std : ndarray, shape (m,), optional
        Standard deviation of each torque equation's noise for the bound; default the
        residual's root mean square.
    instrument_lags : tuple of int, optional
        Two-stage least squares: the design built from the feedback this many samples
        earlier (at the sample's own phase) instruments the design, which removes the bias
        of noise that reaches the fed-back states within a sample. The samples must be
        consecutive in time; the first ``max(lags)`` are dropped. Empty (default): ordinary
        least squares, which is also used, and ``reason`` says why, when a torque's schedule
        has fewer than :data:`MIN_SAMPLES_PER_PARAMETER` samples per parameter.
    segments : ndarray of int, shape (N,), optional
        Several records sharing the controller (windows, episodes, trials): the label of
        each sample's record, each record one run of consecutive samples. Lags stay inside a
        record (its first ``max(lags)`` samples are dropped); the information of all records
        is summed. Default: one record.
    instrument_feedback : ndarray, shape (N, n_s), optional
        The signals the instruments are built from (lagged as ``instrument_lags`` says);
        default ``feedback``. An instrument needs to follow the fed-back states, not to equal
        them: signals free of an error that lagged ``feedback`` shares with ``feedback`` make
        the fit consistent where lagged ``feedback`` would not (the smoother's node rates and
        the midpoint rule's odd-even mode:
        :meth:`colloc.identify.gait.smoother_results.SmoothedGait.instrument_states`).

    Returns
    -------
    ScheduleEstimate

    Raises
    ------
    ValueError
        When the arrays disagree in shape or are not finite, fewer than two blocks are
        given, or the data do not determine a schedule point (as
        :func:`colloc.identify.fit_gain_schedule`).
    """
    P, m, ns = controller.num_points, len(controller.inputs), len(controller.feedback)
    phase, feedback, inputs, problems = schedule_data(controller, phase, feedback, inputs)
    blocks = np.asarray(blocks)
    if blocks.shape != phase.shape:
        problems.append(f"blocks: expected shape {phase.shape}, found {blocks.shape}")
    if not problems and np.unique(blocks).size < 2:
        problems.append("blocks: expected at least two blocks (strides) for the sandwich")
    if noise_std is not None and np.shape(noise_std) != (m,):
        problems.append(f"noise_std: expected shape ({m},), found {np.shape(noise_std)}")
    lags = tuple(instrument_lags)
    if any(isinstance(g, bool) or not isinstance(g, int | np.integer) or g < 1 for g in lags):
        problems.append(f"instrument_lags: expected whole numbers >= 1, found {lags!r}")
    elif lags and max(lags) >= phase.shape[0] // 2:
        problems.append(
            f"instrument_lags: {max(lags)} samples leave too few of the {phase.shape[0]}"
        )
    if segments is None:
        segments = np.zeros(phase.shape[0], dtype=int)
    segments = np.asarray(segments)
    if segments.shape != phase.shape:
        problems.append(f"segments: expected shape {phase.shape}, found {segments.shape}")
    elif np.unique(segments).size != 1 + np.count_nonzero(segments[1:] != segments[:-1]):
        problems.append("segments: expected each record to be one run of consecutive samples")
    if instrument_feedback is None:
        instrument_feedback = feedback
    instrument_feedback = np.asarray(instrument_feedback, dtype=float)
    if instrument_feedback.shape != feedback.shape:
        problems.append(
            f"instrument_feedback: expected shape {feedback.shape}, found "
            f"{instrument_feedback.shape}"
        )
    elif not np.all(np.isfinite(instrument_feedback)):
        problems.append("instrument_feedback: expected finite values, found NaN or inf")
    if problems:
        raise ValueError("fit_schedule_with_errors: " + "; ".join(problems))
    method, reason = "least squares", "asked for"
    if lags and not instruments_pay(controller, phase.shape[0]):
        per_parameter = samples_per_parameter(controller, phase.shape[0])
        reason = (
            f"{per_parameter:.1f} samples per parameter, fewer than the "
            f"{MIN_SAMPLES_PER_PARAMETER:g} at which the instruments pay (a longer record)"
        )
        lags = ()
    elif lags:
        method, reason = (
            "two-stage least squares",
            f"instruments: the feedback {lags} samples earlier",
        )
    # each sample's index inside its record: lags reach back only that far
    starts = np.r_[0, np.flatnonzero(segments[1:] != segments[:-1]) + 1]
    inside = np.arange(phase.shape[0]) - np.repeat(starts, np.diff(np.r_[starts, phase.shape[0]]))
    later = np.flatnonzero(inside >= max(lags, default=0))
    labels = np.unique(blocks[later], return_inverse=True)[1]
    out = {k: np.zeros((P, m)) for k in ("Tstar", "Tstar_se", "Tstar_bound")}
    out |= {k: np.zeros((P, m, ns)) for k in ("K", "K_se", "K_bound")}
    residual_std, used_std = np.zeros(m), np.zeros(m)
    for i in range(m):
        design, allowed = schedule_design(controller, phase[later], feedback[later], i)
        width = 1 + allowed.size
        check_determined(design, width, controller, i)
        target = inputs[later, i]
        # the regressors the estimate uses: the design itself, or its projection on the
        # instruments (then theta = (Dh' D)^-1 Dh' T with Dh' D = Dh' Dh)
        used = design
        if lags:
            lagged = [instrument_feedback[later - lag] for lag in lags]
            instruments = np.hstack(
                [schedule_design(controller, phase[later], s, i)[0] for s in lagged]
            )
            used = instruments @ np.linalg.lstsq(instruments, design, rcond=None)[0]
        normal_inverse = np.linalg.inv(used.T @ design)
        theta = normal_inverse @ (used.T @ target)
        residual = target - design @ theta
        scores = np.zeros((labels.max() + 1, theta.size))
        np.add.at(scores, labels, used * residual[:, None])
        sandwich = normal_inverse @ (scores.T @ scores) @ normal_inverse.T
        residual_std[i] = float(np.sqrt(np.mean(residual**2)))
        used_std[i] = residual_std[i] if noise_std is None else float(noise_std[i])
        bound = used_std[i] ** 2 * np.linalg.inv(design.T @ design)
        for key, values in (
            ("", theta),
            ("_se", np.sqrt(np.clip(np.diag(sandwich), 0.0, None))),
            ("_bound", np.sqrt(np.clip(np.diag(bound), 0.0, None))),
        ):
            values = values.reshape(P, width)
            out["Tstar" + key][:, i] = values[:, 0]
            out["K" + key][:, i, allowed] = values[:, 1:]
    return ScheduleEstimate(
        out["Tstar"],
        out["K"],
        out["Tstar_se"],
        out["K_se"],
        out["Tstar_bound"],
        out["K_bound"],
        residual_std,
        used_std,
        int(labels.max() + 1),
        method,
        reason,
    )


def samples_per_parameter(controller: GainScheduled, num_samples: int) -> float:
    """Samples per parameter of the widest torque's schedule (``P (1 + allowed gains)``).

    Parameters
    ----------
    controller : GainScheduled
    num_samples : int

    Returns
    -------
    float
    """
    width = 1 + int(np.max(np.sum(controller.mask, axis=1)))
    return num_samples / (controller.num_points * width)


def instruments_pay(controller: GainScheduled, num_samples: int) -> bool:
    """Whether ``num_samples`` are enough for the instruments to remove more error than they
    add (:data:`MIN_SAMPLES_PER_PARAMETER`).

    Parameters
    ----------
    controller : GainScheduled
    num_samples : int

    Returns
    -------
    bool
    """
    return samples_per_parameter(controller, num_samples) >= MIN_SAMPLES_PER_PARAMETER


def relative_spread(spread: np.ndarray, reference: np.ndarray) -> float:
    """``sqrt(sum spread^2) / |reference|``: the relative error a set of standard deviations
    stands for, comparable with ``|estimate - truth| / |truth|``."""
    return float(np.sqrt(np.sum(np.asarray(spread) ** 2)) / np.linalg.norm(reference))
