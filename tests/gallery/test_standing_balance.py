"""Gallery: the eight feedback gains of a two-link standing body on a moving platform.

Legs and trunk (ankle and hip joints) stand on a platform that moves along x at the known
speed ``v(t)``; Kane's equations hold ``v'(t)``, declared the measured platform acceleration
``a(t)`` with ``input_derivatives``. Ankle and hip torques come from full-state feedback
``T = -K [q_a, q_h, u_a, u_h]`` designed by LQR on the linearised plant; the eight gains are
estimated from 20 s of noisy joint angles at 200 Hz and checked against the design within
their reported standard errors. Public API only. Reference: SciPy's ``solve_ivp`` of
SymPy's explicit form (``mass_matrix_full``, ``forcing_full``) of the same plant.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm
import sympy.physics.mechanics as me
from scipy.integrate import solve_ivp

import colloc

t = me.dynamicsymbols._t
qa, qh, ua, uh = me.dynamicsymbols("q_a q_h u_a u_h")
Ta, Th, v, a = me.dynamicsymbols("T_a T_h v a")
mL, mT, lL, dL, dT, IL, IT, g = sm.symbols("m_L m_T l_L d_L d_T I_L I_T g", positive=True)
CONSTANTS = {mL: 30.0, mT: 40.0, lL: 0.9, dL: 0.5, dT: 0.3, IL: 2.5, IT: 2.0, g: 9.81}
SIGMA = np.radians(0.1)
TIMES = np.linspace(0.0, 20.0, 4001)  # 200 Hz (at 100 Hz the fastest closed-loop pole,
# -22 rad/s, biases the midpoint rule's gains by about 2.5 standard errors)


def standing_body() -> me.KanesMethod:
    N = me.ReferenceFrame("N")
    legs = N.orientnew("legs", "Axis", (qa, N.z))
    legs.set_ang_vel(N, ua * N.z)
    trunk = legs.orientnew("trunk", "Axis", (qh, legs.z))
    trunk.set_ang_vel(N, (ua + uh) * N.z)
    ankle = me.Point("ankle")
    ankle.set_vel(N, v * N.x)
    legs_mass = ankle.locatenew("legs_mass", dL * legs.y)
    legs_mass.v2pt_theory(ankle, N, legs)
    hip = ankle.locatenew("hip", lL * legs.y)
    hip.v2pt_theory(ankle, N, legs)
    trunk_mass = hip.locatenew("trunk_mass", dT * trunk.y)
    trunk_mass.v2pt_theory(hip, N, trunk)
    bodies = [
        me.RigidBody("L", legs_mass, legs, mL, (me.inertia(legs, 0, 0, IL), legs_mass)),
        me.RigidBody("T", trunk_mass, trunk, mT, (me.inertia(trunk, 0, 0, IT), trunk_mass)),
    ]
    loads = [
        (legs_mass, -mL * g * N.y),
        (trunk_mass, -mT * g * N.y),
        (legs, (Ta - Th) * N.z),
        (trunk, Th * N.z),
    ]
    kane = me.KanesMethod(N, [qa, qh], [ua, uh], kd_eqs=[qa.diff(t) - ua, qh.diff(t) - uh])
    kane.kanes_equations(bodies, loads)
    return kane


def platform(time):
    """Speed and acceleration: six sines between 0.3 and 3 Hz."""
    rng = np.random.default_rng(3)
    freqs = np.array([0.3, 0.55, 0.9, 1.4, 2.1, 3.0])
    amps, phases = rng.uniform(0.5, 1.0, 6), rng.uniform(0.0, 2 * np.pi, 6)
    arg = 2 * np.pi * freqs * np.asarray(time)[..., None] + phases
    return (-amps / (2 * np.pi * freqs) * np.cos(arg)).sum(-1), (amps * np.sin(arg)).sum(-1)


def design_gains(plant: colloc.Model) -> np.ndarray:
    upright = {name: 0.0 for name in ("q_a", "q_h", "u_a", "u_h")}
    upright.update({f"{name}_dot": 0.0 for name in upright})
    ss = colloc.linearize(plant, upright, inputs=[Ta, Th])
    A = np.array(ss.A.subs(CONSTANTS), dtype=float)
    B = np.array(ss.B.subs(CONSTANTS), dtype=float)
    design = colloc.lqr(A, B, np.diag([1.0, 1.0, 0.1, 0.1]), 1e-4 * np.eye(2))
    assert np.all(design.eigenvalues.real < 0)  # upright is stable under the design
    return design.K


def simulate(kane: me.KanesMethod, K: np.ndarray) -> np.ndarray:
    mass = sm.lambdify([qa, qh, ua, uh], kane.mass_matrix_full.subs(CONSTANTS))
    forcing = sm.lambdify(
        [qa, qh, ua, uh, Ta, Th, a, v],
        kane.forcing_full.subs(CONSTANTS).subs({v.diff(t): a}),
    )

    def rhs(time, s):
        torque = -K @ s
        speed, accel = platform(time)
        f = np.asarray(forcing(*s, *torque, accel, speed), dtype=float).ravel()
        return np.linalg.solve(np.asarray(mass(*s), dtype=float), f)

    return solve_ivp(rhs, (0, 20), np.zeros(4), t_eval=TIMES, rtol=1e-10, atol=1e-11).y


@pytest.mark.slow  # 58 s: the gallery example run whole; benchmarks/slow_tests.py runs it
def test_eight_gains_from_noisy_joint_angles_within_their_standard_errors():
    kane = standing_body()
    plant = colloc.Model.from_kane(
        kane, controlled_inputs=[Ta, Th], known_inputs=[v], input_derivatives={v: a}
    )
    K = design_gains(plant)
    angles = simulate(kane, K)[:2]
    measured = angles + np.random.default_rng(8).normal(0.0, SIGMA, angles.shape)

    feedback = colloc.StateFeedback.symbolic(num_inputs=2, num_states=4)
    speed, accel = platform(TIMES)
    problem = colloc.Problem(
        plant.close_loop(feedback),
        TIMES,
        known_trajectories={v: speed, a: accel},
        known_parameters=CONSTANTS,
        objective=colloc.Tracking(
            {qa: measured[0], qh: measured[1]}, weights={qa: SIGMA**-2, qh: SIGMA**-2}
        ),
    )
    rates = np.gradient(measured, TIMES, axis=1)
    guess = problem.initial_guess(
        {qa: measured[0], qh: measured[1], ua: rates[0], uh: rates[1]},
        {k: 0.0 for k in feedback.parameters},
    )
    solution = problem.solve(guess, print_level=0)
    assert solution.success, solution.status
    se = colloc.parameter_uncertainty(problem, solution).standard_errors
    z = [
        (solution.parameters[k] - true) / se[k]
        for k, true in zip(feedback.parameters, K.ravel(), strict=True)
    ]
    assert np.all(np.abs(z) < 3), np.round(z, 2)
    # and the data do determine them: the largest gains to a few percent
    assert se[feedback.parameters[0]] < 0.05 * K[0, 0]
