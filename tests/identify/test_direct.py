"""Direct identification (least squares on the equations of motion) and the smoother behind it.

References: the gains of an LQR-closed pendulum simulated by SciPy with derivatives from the
ODE's right-hand side; an analytic mass-spring-damper trajectory; analytic derivatives of
polynomials and sines.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, StateFeedback, linearize, lqr
from colloc.identify import direct_estimate, smooth_with_derivatives
from colloc.models import pendulum_cart
from colloc.simulate import ImplicitODE, SumOfSines

t = dynamicsymbols._t


@pytest.fixture(scope="module")
def pendulum():
    """Noise-free 1-link closed-loop data with exact state derivatives."""
    plant = pendulum_cart.derive(1)
    model = plant.to_model()
    constants = plant.default_constants()
    ss = linearize(
        model,
        dict.fromkeys(model.states, 0.0),
        inputs=plant.torques,
        constants=constants,
        equilibrium=True,
        numeric=True,
    )
    known = np.asarray(lqr(ss.A, ss.B, np.eye(4), np.eye(1)).K, dtype=float).ravel()
    feedback = StateFeedback.symbolic(1, 4)
    closed = model.close_loop(feedback)
    gains = list(feedback.K)
    times = np.arange(501) / 50.0
    force_fn = SumOfSines.from_seed(10.0, 1)
    ode = ImplicitODE.from_model(
        closed, {**constants, **dict(zip(gains, known, strict=True))}, {plant.force: force_fn}
    )
    states = ode.simulate(np.zeros(4), times)
    derivatives = np.array([ode.rhs(tk, xk) for tk, xk in zip(times, states, strict=True)])
    return {
        "plant": plant,
        "closed": closed,
        "gains": gains,
        "known": known,
        "constants": constants,
        "times": times,
        "states": states,
        "derivatives": derivatives,
        "inputs": {plant.force: force_fn(times)},
    }


def _by_name(symbols, name):
    return next(s for s in symbols if str(s) == name)


def test_recovers_lqr_gains_from_exact_states_and_derivatives(pendulum):
    p = pendulum
    estimate = direct_estimate(
        p["closed"],
        p["gains"],
        p["times"],
        p["states"],
        p["derivatives"],
        p["inputs"],
        p["constants"],
    )
    assert set(estimate) == set(p["gains"])
    found = np.array([estimate[k] for k in p["gains"]])
    np.testing.assert_allclose(found, p["known"], rtol=1e-6)


def test_recovers_gains_and_gravity_together(pendulum):
    # g enters m g l sin(q) linearly, so it can join the gains in one linear fit.
    p = pendulum
    g = _by_name(p["constants"], "g")
    others = {k: v for k, v in p["constants"].items() if k != g}
    estimate = direct_estimate(
        p["closed"],
        [*p["gains"], g],
        p["times"],
        p["states"],
        p["derivatives"],
        p["inputs"],
        others,
    )
    assert estimate[g] == pytest.approx(9.81, rel=1e-6)
    np.testing.assert_allclose([estimate[k] for k in p["gains"]], p["known"], rtol=1e-6)


def test_smoothed_noise_free_samples_give_gains_close_to_the_truth(pendulum):
    # Derivatives by Savitzky-Golay instead of the ODE: the only error is the smoother's
    # truncation error, which grows with the window (about as its square).
    p = pendulum
    errors = []
    for window in (0.1, 0.18, 0.3):  # 5, 9 and 15 samples at 50 Hz
        q, qd, qdd = smooth_with_derivatives(p["times"], p["states"][:, :2], window)
        estimate = direct_estimate(
            p["closed"],
            p["gains"],
            p["times"],
            np.hstack([q, qd]),
            np.hstack([qd, qdd]),
            p["inputs"],
            p["constants"],
        )
        found = np.array([estimate[k] for k in p["gains"]])
        errors.append(np.max(np.abs(found - p["known"]) / np.abs(p["known"])))
    assert errors[0] < 0.015
    assert errors[0] < errors[1] < errors[2] < 0.1
    assert errors[2] / errors[0] > 4.0


def _spring_damper():
    x, v, f = dynamicsymbols("x v f")
    m, c, k = sm.symbols("m c k")
    model = Model.from_equations(
        [x.diff(t) - v, m * v.diff(t) + c * v + k * x - f], [x, v], known_inputs=[f]
    )
    return model, (x, v, f), (m, c, k)


def test_spring_damper_from_an_analytic_trajectory():
    # x = sin(2t) + 0.3 cos(t); f is whatever force makes that the motion.
    model, (x, v, f), (m, c, k) = _spring_damper()
    times = np.linspace(0.0, 5.0, 101)
    pos = np.sin(2 * times) + 0.3 * np.cos(times)
    vel = 2 * np.cos(2 * times) - 0.3 * np.sin(times)
    acc = -4 * np.sin(2 * times) - 0.3 * np.cos(times)
    force = 2.0 * acc + 0.7 * vel + 3.0 * pos
    estimate = direct_estimate(
        model,
        [c, k],
        times,
        np.column_stack([pos, vel]),
        np.column_stack([vel, acc]),
        {f: force},
        {m: 2.0},
    )
    assert estimate[c] == pytest.approx(0.7, rel=1e-10)
    assert estimate[k] == pytest.approx(3.0, rel=1e-10)


# ----------------------------------------------------------------------------- error paths


def test_parameter_entering_nonlinearly_is_rejected(pendulum):
    p = pendulum
    length = _by_name(p["constants"], "l0")
    others = {k: v for k, v in p["constants"].items() if k != length}
    with pytest.raises(ValueError, match=r"unknown: the residual is not affine in \['l0'\]"):
        direct_estimate(
            p["closed"],
            [*p["gains"], length],
            p["times"],
            p["states"],
            p["derivatives"],
            p["inputs"],
            others,
        )


def test_missing_inputs_are_rejected(pendulum):
    p = pendulum
    with pytest.raises(ValueError, match=r"known_inputs: no values for inputs \['F'\]"):
        direct_estimate(
            p["closed"],
            p["gains"],
            p["times"],
            p["states"],
            p["derivatives"],
            {},
            p["constants"],
        )


def test_missing_parameters_are_rejected():
    model, (x, v, f), (m, c, k) = _spring_damper()
    times = np.linspace(0.0, 1.0, 11)
    ones = np.ones((11, 2))
    with pytest.raises(ValueError, match=r"known_parameters: no values for \['m'\]"):
        direct_estimate(model, [c, k], times, ones, ones, {f: np.zeros(11)}, {})


@pytest.mark.parametrize(
    ("states_shape", "derivatives_shape", "message"),
    [
        ((10, 2), (11, 2), r"states: expected shape \(11, 2\), found \(10, 2\)"),
        ((11, 2), (11, 3), r"state_derivatives: expected shape \(11, 2\), found \(11, 3\)"),
        ((11,), (11, 2), r"states: expected shape \(11, 2\), found \(11,\)"),
    ],
)
def test_bad_shapes_are_rejected(states_shape, derivatives_shape, message):
    model, (x, v, f), (m, c, k) = _spring_damper()
    times = np.linspace(0.0, 1.0, 11)
    with pytest.raises(ValueError, match=message):
        direct_estimate(
            model,
            [c, k],
            times,
            np.ones(states_shape),
            np.ones(derivatives_shape),
            {f: np.zeros(11)},
            {m: 1.0},
        )


def test_every_problem_is_reported_at_once():
    model, (x, v, f), (m, c, k) = _spring_damper()
    times = np.linspace(0.0, 1.0, 11)
    with pytest.raises(ValueError) as info:
        direct_estimate(model, [c, k], times, np.ones((3, 2)), np.ones((11, 2)), {}, {})
    text = str(info.value)
    for part in ("states: expected shape", "known_inputs: no values", "known_parameters"):
        assert part in text


# ----------------------------------------------------------------------------- smoothing


def test_smoothing_is_exact_for_a_cubic_including_the_edges():
    # A cubic Savitzky-Golay filter reproduces any cubic and its derivatives exactly.
    times = np.arange(0.0, 2.0 + 1e-12, 0.01)
    value = 1.0 - 2.0 * times + 0.5 * times**2 + 0.75 * times**3
    first = -2.0 + times + 2.25 * times**2
    second = 1.0 + 4.5 * times
    q, qd, qdd = smooth_with_derivatives(times, value, 0.15)
    np.testing.assert_allclose(q, value, atol=1e-10)
    np.testing.assert_allclose(qd, first, atol=1e-8)
    np.testing.assert_allclose(qdd, second, atol=1e-6)


def test_smoothing_matches_analytic_derivatives_of_a_sine():
    # 1 Hz sine at 100 Hz, 15-sample window of half-width a = 0.07 s. Least squares of t^4
    # on {1, t^2} over [-a, a] gives 6 a^2 t^2 / 7, so the fitted second derivative is
    # f'' + f'''' a^2 / 14: a relative error of (omega a)^2 / 14 ~ 1.4e-2. The value and
    # first derivative are fitted to higher order, so their error is far smaller.
    omega = 2 * np.pi
    times = np.arange(0.0, 3.0 + 1e-12, 0.01)
    values = np.column_stack([np.sin(omega * times), np.cos(omega * times)])
    q, qd, qdd = smooth_with_derivatives(times, values, 0.15)
    interior = slice(10, -10)
    np.testing.assert_allclose(q[interior], values[interior], atol=2e-3)
    np.testing.assert_allclose(
        qd[interior] / omega, values[interior] @ [[0, -1], [1, 0]], atol=5e-3
    )
    np.testing.assert_allclose(qdd[interior] / omega**2, -values[interior], atol=2e-2)


def test_smoothing_rejects_non_uniform_times():
    times = np.array([0.0, 0.1, 0.2, 0.35, 0.4, 0.5, 0.6])
    with pytest.raises(ValueError, match="times: expected uniform sampling"):
        smooth_with_derivatives(times, np.zeros(7), 0.3)


def test_smoothing_rejects_a_window_longer_than_the_record():
    times = np.arange(11) * 0.01
    with pytest.raises(ValueError, match=r"window: 0.5 s spans 51 samples, more than the 11"):
        smooth_with_derivatives(times, np.zeros(11), 0.5)


# ---------------------------------------------------------------- gain schedule (direct ID)


def _schedule_data(controller, num_samples, cycles, rng, noise=0.0):
    """Phases over ``cycles`` strides, random feedback, the law's torques (+ noise)."""
    P, m, ns = controller.num_points, len(controller.inputs), len(controller.feedback)
    Tstar = rng.normal(0.0, 20.0, (P, m))
    K = rng.normal(0.0, 50.0, (P, m, ns)) * controller.mask
    phase = np.linspace(0.0, cycles, num_samples, endpoint=False) + 0.3
    s = rng.normal(0.0, 0.2, (num_samples, ns))
    torques = controller.torque(phase, s, Tstar, K) + noise * rng.standard_normal((num_samples, m))
    return Tstar, K, phase, s, torques


@pytest.mark.parametrize("structure", ["full", "joint-isolated"])
def test_fit_gain_schedule_recovers_an_exact_law(structure):
    from colloc import GainScheduled
    from colloc.identify import fit_gain_schedule

    s_syms = dynamicsymbols("s0:4")
    controller = GainScheduled(5, s_syms, dynamicsymbols("T0:2"), structure=structure)
    rng = np.random.default_rng(3)
    Tstar, K, phase, s, torques = _schedule_data(controller, 900, 6.0, rng)
    fit = fit_gain_schedule(controller, phase, s, torques)
    np.testing.assert_allclose(fit.Tstar, Tstar, rtol=0, atol=1e-9 * np.abs(Tstar).max())
    np.testing.assert_allclose(fit.K, K, rtol=0, atol=1e-9 * np.abs(K).max())
    assert np.all(fit.K[:, ~controller.mask] == 0.0)
    assert np.abs(fit.residual).max() < 1e-9 * np.abs(torques).max()


def test_fit_gain_schedule_residual_is_the_torque_noise():
    # with noise on the torques only, the least-squares residual has the noise's spread
    # (reduced by the fitted parameters' share of the samples) and the estimate is unbiased
    from colloc import GainScheduled
    from colloc.identify import fit_gain_schedule

    controller = GainScheduled(4, dynamicsymbols("s0:2"), dynamicsymbols("T0:1"))
    rng = np.random.default_rng(5)
    errors = []
    for _ in range(30):
        Tstar, K, phase, s, torques = _schedule_data(controller, 2000, 20.0, rng, noise=1.0)
        fit = fit_gain_schedule(controller, phase, s, torques)
        dof = 2000 - 4 * 3
        assert np.sum(fit.residual**2) / dof == pytest.approx(1.0, abs=0.12)
        errors.append(fit.Tstar[:, 0] - Tstar[:, 0])
    mean, spread = np.mean(errors, axis=0), np.std(errors, axis=0)
    assert np.all(np.abs(mean) < 4 * spread / np.sqrt(30))


def test_fit_gain_schedule_names_points_without_data():
    from colloc import GainScheduled
    from colloc.identify import fit_gain_schedule

    controller = GainScheduled(10, dynamicsymbols("s0:2"), dynamicsymbols("T0:1"))
    rng = np.random.default_rng(1)
    # less than half a stride: the points in the unvisited half are undetermined
    phase = np.linspace(0.0, 0.4, 200)
    s = rng.normal(size=(200, 2))
    with pytest.raises(ValueError, match=r"input T0 at \d+ of 10 points.*point 6 \(phase 0.600\)"):
        fit_gain_schedule(controller, phase, s, rng.normal(size=(200, 1)))


def test_fit_gain_schedule_rejects_misshapen_and_nonfinite_data():
    from colloc import GainScheduled
    from colloc.identify import fit_gain_schedule

    controller = GainScheduled(3, dynamicsymbols("s0:2"), dynamicsymbols("T0:1"))
    phase = np.linspace(0.0, 3.0, 50)
    s = np.ones((50, 2))
    s[4, 1] = np.nan
    with pytest.raises(ValueError) as info:
        fit_gain_schedule(controller, phase, s, np.ones((50, 2)))
    assert "feedback: expected finite values" in str(info.value)
    assert "inputs: expected shape (50, 1), found (50, 2)" in str(info.value)
