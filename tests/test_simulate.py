"""Tests of excitation signals, sensor noise and the implicit forward simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc.control import StateFeedback
from colloc.model.model import Model
from colloc.models.pendulum_cart import derive
from colloc.simulate import (
    ImplicitODE,
    SimulationError,
    SumOfSines,
    add_sensor_noise,
    random_phases,
    seed_frequencies,
    simulate,
    sum_of_sines,
)

T = dynamicsymbols._t
SEED_GAINS = [[-4.71764346, 19.67083668, -3.69402157, 5.57114809]]

# Damped oscillator x'' + 2 zeta w x' + w^2 x = r, written with a full (non-diagonal)
# mass matrix A: A [x' - v, v' + 2 zeta w v + w^2 x - r] = 0.
W, ZETA = 2.0, 0.1
A = np.array([[2.0, 1.0], [1.0, 3.0]])


def _oscillator_exact(times: np.ndarray, x0: float, v0: float, r0: float) -> np.ndarray:
    wd = W * math.sqrt(1 - ZETA**2)
    xs = r0 / W**2
    a = x0 - xs
    b = (v0 + ZETA * W * a) / wd
    decay = np.exp(-ZETA * W * times)
    x = xs + decay * (a * np.cos(wd * times) + b * np.sin(wd * times))
    v = decay * (
        -ZETA * W * (a * np.cos(wd * times) + b * np.sin(wd * times))
        + wd * (-a * np.sin(wd * times) + b * np.cos(wd * times))
    )
    return np.column_stack([x, v])


def test_seed_frequencies() -> None:
    w = seed_frequencies()
    assert w.shape == (12,)
    assert w[0] == pytest.approx(2 * math.pi * 7 / 240)
    assert w[-1] == pytest.approx(2 * math.pi * 523 / 240)


def test_sum_of_sines_matches_hand_value() -> None:
    value = sum_of_sines(0.3, [1.0, 2.0], [2.0, 0.5], [0.0, math.pi / 2])
    assert value == pytest.approx(2 * math.sin(0.3) + 0.5 * math.cos(0.6), abs=1e-15)
    signal = SumOfSines(np.array([1.0, 2.0]), np.array([2.0, 0.5]), np.array([0.0, math.pi / 2]))
    times = np.array([[0.3, 1.0], [2.0, -1.5]])
    expected = 2 * np.sin(times) + 0.5 * np.cos(2 * times)
    np.testing.assert_allclose(signal(times), expected, atol=1e-15)
    assert signal(0.3) == pytest.approx(float(value), abs=1e-15)
    assert isinstance(signal(2), float)


def test_from_seed_is_reproducible_and_phases_are_in_range() -> None:
    first, again, other = (SumOfSines.from_seed(0.5, s) for s in (7, 7, 8))
    np.testing.assert_array_equal(first.phases, again.phases)
    assert not np.allclose(first.phases, other.phases)
    assert np.all((first.phases >= 0) & (first.phases < 2 * math.pi))
    np.testing.assert_array_equal(first.amplitudes, np.full(12, 0.5))
    np.testing.assert_array_equal(first.phases, random_phases(12, 7))
    t = 13.7
    hand = sum(
        0.5 * math.sin(w * t + p) for w, p in zip(first.frequencies, first.phases, strict=True)
    )
    assert first(t) == pytest.approx(hand, abs=1e-13)


def test_simulate_matches_damped_oscillator_with_full_mass_matrix() -> None:
    def mass(_x: np.ndarray, _t: float) -> np.ndarray:
        return A

    def forcing(x: np.ndarray, _t: float) -> np.ndarray:
        return A @ np.array([x[1], -2 * ZETA * W * x[1] - W**2 * x[0] + 1.5])

    times = np.linspace(0, 10, 501)
    states = simulate(mass, forcing, [1.0, -0.5], times)
    np.testing.assert_allclose(states, _oscillator_exact(times, 1.0, -0.5, 1.5), atol=1e-8)
    second = simulate(mass, forcing, [1.0, -0.5], times, method="DOP853")
    np.testing.assert_allclose(second, states, atol=1e-8)


def _oscillator_model() -> tuple[Model, tuple]:
    x, v, r = dynamicsymbols("x v r")
    w, zeta = sm.symbols("w zeta")
    eqs = sm.Matrix([x.diff(T) - v, v.diff(T) + 2 * zeta * w * v + w**2 * x - r])
    residual = sm.Matrix(A.tolist()) * eqs
    model = Model.from_equations(residual, [x, v], known_inputs=[r])
    return model, (r, w, zeta)


def test_implicit_ode_from_model_matches_analytic_solution() -> None:
    model, (r, w, zeta) = _oscillator_model()
    ode = ImplicitODE.from_model(model, {w: W, zeta: ZETA}, {r: lambda _t: 1.5})
    np.testing.assert_allclose(ode.mass(np.zeros(2), 0.0), A)
    times = np.linspace(0, 10, 501)
    states = ode.simulate([1.0, -0.5], times)
    np.testing.assert_allclose(states, _oscillator_exact(times, 1.0, -0.5, 1.5), atol=1e-8)
    np.testing.assert_allclose(
        ode.rhs(0.0, [1.0, -0.5]), [-0.5, -(W**2) + 2 * ZETA * W * 0.5 + 1.5]
    )


def _one_link_closed_loop(gains: list[list[float]]) -> tuple[ImplicitODE, SumOfSines]:
    sys = derive(1)
    closed = sys.to_model().close_loop(StateFeedback(gains))
    force = SumOfSines.from_seed(1.0, 2)
    return ImplicitODE.from_model(closed, sys.default_constants(), {sys.force: force}), force


def test_one_link_closed_loop_stays_bounded_under_seed_gains() -> None:
    ode, _ = _one_link_closed_loop(SEED_GAINS)
    times = np.arange(0, 60, 0.01)
    states = ode.simulate([0.0, 0.05, 0.0, 0.0], times)
    assert states.shape == (6000, 4)
    assert np.abs(states[:, 1]).max() < 0.5
    assert np.abs(states).max() < 2.0
    # Same trajectory from an independent integrator.
    check = ode.simulate([0.0, 0.05, 0.0, 0.0], times[:1001], method="DOP853")
    np.testing.assert_allclose(check, states[:1001], atol=1e-6)


def test_one_link_without_feedback_falls_over() -> None:
    ode, _ = _one_link_closed_loop([[0.0, 0.0, 0.0, 0.0]])
    states = ode.simulate([0.0, 0.05, 0.0, 0.0], np.linspace(0, 5, 51))
    assert np.abs(states[:, 1]).max() > 1.0


def test_add_sensor_noise_statistics_and_reproducibility() -> None:
    clean = np.ones((20000, 2))
    noisy = add_sensor_noise(clean, [0.1, 0.01], seed=4)
    np.testing.assert_array_equal(clean, 1.0)
    np.testing.assert_allclose((noisy - clean).std(axis=0), [0.1, 0.01], rtol=0.03)
    np.testing.assert_allclose((noisy - clean).mean(axis=0), 0.0, atol=2e-3)
    np.testing.assert_array_equal(noisy, add_sensor_noise(clean, [0.1, 0.01], seed=4))
    assert not np.array_equal(noisy, add_sensor_noise(clean, [0.1, 0.01], seed=5))
    np.testing.assert_array_equal(add_sensor_noise(np.zeros(5), 0.0, seed=1), 0.0)


# ------------------------------------------------------------------------------ error paths


def _identity(_x: np.ndarray, _t: float) -> np.ndarray:
    return np.eye(2)


def _zero(_x: np.ndarray, _t: float) -> np.ndarray:
    return np.zeros(2)


def test_simulate_reports_all_bad_arguments() -> None:
    with pytest.raises(ValueError, match=r"x0 must be finite") as info:
        simulate(_identity, _zero, [np.nan, 0.0], [0.0, 1.0, 1.0], method="Euler", rtol=-1)
    message = str(info.value)
    assert "times must be finite and strictly increasing" in message
    assert "method must be one of" in message
    assert "rtol must be a positive finite number, found -1" in message


def test_simulate_checks_callable_shapes() -> None:
    with pytest.raises(
        ValueError, match=r"mass\(x0, t0\) must have shape \(3, 3\), found \(2, 2\)"
    ):
        simulate(_identity, _zero, [0.0, 0.0, 0.0], [0.0, 1.0])


def test_singular_mass_matrix_raises_simulation_error() -> None:
    def singular(_x: np.ndarray, _t: float) -> np.ndarray:
        return np.ones((2, 2))

    with pytest.raises(SimulationError, match=r"mass matrix is singular at t = 0"):
        simulate(singular, _zero, [1.0, 0.0], [0.0, 1.0])


def test_integration_failure_carries_solver_message() -> None:
    # x' = x^2 from x(0) = 1 blows up at t = 1.
    def blow_up(x: np.ndarray, _t: float) -> np.ndarray:
        return x**2

    with pytest.raises(SimulationError, match=r"integration with RK45 failed near t = 1"):
        simulate(_identity, blow_up, [1.0, 1.0], [0.0, 2.0], method="RK45")


def test_from_model_reports_missing_and_unknown_values() -> None:
    model, (r, w, _zeta) = _oscillator_model()
    stray = sm.Symbol("stray")
    with pytest.raises(ValueError, match=r"parameter_values lacks \['zeta'\]") as info:
        ImplicitODE.from_model(model, {w: 1.0, stray: 2.0}, {dynamicsymbols("s"): math.sin})
    message = str(info.value)
    assert "unknown parameter(s) ['stray']" in message
    assert "known_inputs lacks a function for ['r(t)']" in message
    assert "the model does not have: ['s(t)']" in message


def test_from_residual_rejects_nonlinear_and_incomplete_residuals() -> None:
    x, v, r = dynamicsymbols("x v r")
    a = sm.Symbol("a")
    residual = [x.diff(T) ** 2 - v, v.diff(T) + a * x - r]
    with pytest.raises(ValueError, match=r"not linear in the state derivatives") as info:
        ImplicitODE.from_residual(residual, [x, v], [x.diff(T), v.diff(T)], {}, {}, t=T)
    message = str(info.value)
    assert "symbols without a value in parameter_values: ['a']" in message
    assert "neither states nor given inputs: ['r(t)']" in message


def test_from_residual_rejects_non_square_and_uncallable_inputs() -> None:
    x, r = dynamicsymbols("x r")
    with pytest.raises(ValueError, match=r"residual must be a column of length 1") as info:
        ImplicitODE.from_residual([x.diff(T), x], [x], [x.diff(T)], {}, {r: 3.0}, t=T)
    assert "inputs for ['r(t)'] are not callable" in str(info.value)


def test_implicit_ode_simulate_checks_x0_length() -> None:
    model, (r, w, zeta) = _oscillator_model()
    ode = ImplicitODE.from_model(model, {w: W, zeta: ZETA}, {r: lambda _t: 0.0})
    with pytest.raises(ValueError, match=r"x0 must have 2 entries \(one per state\), found 3"):
        ode.simulate([0.0, 0.0, 0.0], [0.0, 1.0])


def test_excitation_and_noise_argument_errors() -> None:
    with pytest.raises(ValueError, match=r"equal length, found \{'frequencies': 2"):
        sum_of_sines(0.0, [1.0, 2.0], [1.0], [0.0])
    with pytest.raises(ValueError, match=r"num: expected an integer >= 0, found -1"):
        random_phases(-1, seed=0)
    with pytest.raises(ValueError, match=r"one entry per column of array \(shape \(4, 2\)\)"):
        add_sensor_noise(np.zeros((4, 2)), [0.1, 0.2, 0.3], seed=0)
    with pytest.raises(ValueError, match=r"std must be finite and >= 0"):
        add_sensor_noise(np.zeros(4), -1.0, seed=0)


def test_sampled_noise_is_reproducible_has_its_spread_and_is_linear_between_samples():
    from colloc.simulate import SampledNoise

    times = np.arange(20001) * 0.01
    a = SampledNoise.draw(times, 2.0, seed=3)
    b = SampledNoise.draw(times, 2.0, seed=3)
    np.testing.assert_array_equal(a.values, b.values)
    assert np.std(a.values) == pytest.approx(2.0, rel=0.03)
    assert abs(np.mean(a.values)) < 4 * 2.0 / np.sqrt(times.size)
    mid = 0.5 * (times[:-1] + times[1:])
    np.testing.assert_allclose(a(mid), 0.5 * (a.values[:-1] + a.values[1:]))
    with pytest.raises(ValueError, match="std: expected a finite number >= 0"):
        SampledNoise.draw(times, -1.0, seed=0)
    with pytest.raises(ValueError, match="strictly increasing"):
        SampledNoise.draw(times[::-1], 1.0, seed=0)
