"""The Laplace marginal likelihood's correction of a maximum a posteriori fit.

Reference: the exact likelihood of the same discrete model, computed by a Kalman filter
written here (the midpoint recursion of a mass-spring-damper driven by a known force and
white process noise, the state augmented with the disturbance's node value, the initial
position and speed diffuse as the fit's free initial state is) and maximised by SciPy. For
a linear model with Gaussian noise the Laplace form is exact, so the corrected estimate must
land on the filter's maximum; the joint estimate does not (its damping is biased low by
about 0.7 standard errors, 9 % of the damping over 100 realisations: ``docs/process-noise.md``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import test_process_noise as msd
from scipy.optimize import minimize

from colloc import parameter_uncertainty
from colloc.nlp.marginal import marginal_correction


def kalman_negative_log_likelihood(theta: np.ndarray, measured: np.ndarray) -> float:
    """``-2 log p(y | c, k)`` up to a constant, by the Kalman filter of the midpoint
    recursion (diffuse initial position and speed: a prior variance of 1e6)."""
    c, k = theta
    h = msd.H
    A = np.array([[1.0, -h / 2], [k * h / 2, msd.MASS + c * h / 2]])
    B = np.array([[1.0, h / 2], [-k * h / 2, msd.MASS - c * h / 2]])
    pushed = np.linalg.solve(A, [0.0, h])  # a unit force over an interval
    F = np.zeros((3, 3))
    F[:2, :2] = np.linalg.solve(A, B)
    F[:2, 2] = 0.5 * pushed  # the disturbance enters as the mean of its two nodes
    G = np.r_[0.5 * pushed, 1.0]
    Q = msd.SIGMA_W**2 * np.outer(G, G)
    mean, P = np.zeros(3), np.diag([1e6, 1e6, msd.SIGMA_W**2])
    total = 0.0
    for j, y in enumerate(measured):
        if j:
            mean = F @ mean + np.r_[msd.FORCE_MID[j - 1] * pushed, 0.0]
            P = F @ P @ F.T + Q
        S = P[0, 0] + msd.SIGMA_Y**2
        r = y - mean[0]
        total += np.log(S) + r * r / S
        gain = P[:, 0] / S
        mean = mean + gain * r
        P = P - np.outer(gain, P[0])
        P = 0.5 * (P + P.T)
    return total


@pytest.mark.parametrize("seed", [0, 1])
def test_the_correction_lands_on_the_exact_likelihoods_maximum(seed):
    measured = msd.realisation(seed)
    problem, solution = msd.fit(measured, True)
    joint = np.array([solution.parameters[msd.c], solution.parameters[msd.k]])
    exact = minimize(
        kalman_negative_log_likelihood,
        joint,
        args=(measured,),
        method="Nelder-Mead",
        options={"xatol": 1e-7, "fatol": 1e-9, "maxiter": 4000},
    ).x
    result = marginal_correction(problem, solution)
    corrected = np.array([result.parameters[msd.c], result.parameters[msd.k]])
    se = parameter_uncertainty(problem, solution, method="kkt", discretisation=False)
    se = np.array([se.standard_errors[msd.c], se.standard_errors[msd.k]])
    gap = np.abs(joint - exact)
    assert gap[0] > 0.5 * se[0]  # the joint estimate's damping is off the likelihood's
    # the correction removes at least 90 % of the gap, and is within 5 % of an SE of it
    assert np.all(np.abs(corrected - exact) < 0.1 * gap + 1e-3 * se)
    assert np.all(np.abs(corrected - exact) < 0.05 * se)
    assert result.shift[msd.c] == pytest.approx(corrected[0] - joint[0])
    assert result.shift_in_se[msd.c] > 0.5
    assert result.noise_variance == pytest.approx(1.0, abs=0.1)  # weights 1 / sigma^2
    assert 1 <= result.iterations <= 5


def test_bad_requests_are_refused_by_name():
    measured = msd.realisation(3)
    problem, solution = msd.fit(measured, False)
    with pytest.raises(ValueError, match="no noise model"):
        marginal_correction(problem, solution)
    problem, solution = msd.fit(measured, True)
    with pytest.raises(ValueError, match="noise_variance: expected a number > 0"):
        marginal_correction(problem, solution, noise_variance=-1.0)
    with pytest.raises(ValueError, match="noise_variance: expected a number > 0, found 'one'"):
        marginal_correction(problem, solution, noise_variance="one")
    with pytest.raises(ValueError, match="max_iterations: expected a whole number >= 1"):
        marginal_correction(problem, solution, max_iterations=0)
    cut = dataclasses.replace(solution, z=solution.z[:-1])
    with pytest.raises(ValueError, match="not a solve of this problem"):
        marginal_correction(problem, cut)
