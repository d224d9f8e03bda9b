"""IPOPT's C interface through ctypes (``colloc.solve.ipopt_capi``) on a problem solved by hand.

``min (x0 - 1)^2 + (x1 - 2)^2  s.t.  x0 + x1 = 1``: the optimum is ``x = (0, 1)``, and with
IPOPT's ``L = f + lambda g`` the stationarity ``2 (x - (1, 2)) + lambda (1, 1) = 0`` gives
``lambda = 2``.
"""

from __future__ import annotations

import numpy as np
import pytest

from colloc.solve.ipopt_capi import CProblem, library_path


class Quadratic:
    def __init__(self, fail_in=None, wrong_size_in=None):
        self.fail_in, self.wrong_size_in = fail_in, wrong_size_in
        self.iterations = 0

    def _check(self, name, value):
        if name == self.fail_in:
            raise RuntimeError(f"boom in {name}")
        if name == self.wrong_size_in:
            return np.r_[value, 0.0]
        return value

    def objective(self, x):
        return float(self._check("objective", (x[0] - 1) ** 2 + (x[1] - 2) ** 2))

    def gradient(self, x):
        return self._check("gradient", np.array([2 * (x[0] - 1), 2 * (x[1] - 2)]))

    def constraints(self, x):
        return self._check("constraints", np.array([x[0] + x[1] - 1]))

    def jacobianstructure(self):
        return np.array([0, 0]), np.array([0, 1])

    def jacobian(self, x):
        return self._check("jacobian", np.array([1.0, 1.0]))

    def hessianstructure(self):
        return np.array([0, 1]), np.array([0, 1])

    def hessian(self, x, lagrange, obj_factor):
        return self._check("hessian", np.array([2.0, 2.0]) * obj_factor)

    def intermediate(self, *args):
        self.iterations = int(args[1])
        return True


def solve(callbacks, **options):
    problem = CProblem(
        2, 1, callbacks, np.full(2, -1e20), np.full(2, 1e20), np.zeros(1), np.zeros(1)
    )
    try:
        problem.add_option("print_level", 0)
        problem.add_option("sb", "yes")
        for key, value in options.items():
            problem.add_option(key, value)
        return problem.solve(np.array([5.0, -3.0]))
    finally:
        problem.close()


def test_solves_the_quadratic_to_its_analytic_optimum():
    callbacks = Quadratic()
    x, info = solve(callbacks, tol=1e-12)
    assert info["status"] == 0
    np.testing.assert_allclose(x, [0.0, 1.0], atol=1e-10)
    # stationarity 2 (x - (1, 2)) + lambda (1, 1) = 0 at x = (0, 1): lambda = 2
    np.testing.assert_allclose(info["mult_g"], [2.0], atol=1e-8)
    assert info["obj_val"] == pytest.approx(2.0)
    np.testing.assert_allclose(info["g"], [0.0], atol=1e-12)
    assert callbacks.iterations >= 1


@pytest.mark.parametrize("where", ["objective", "gradient", "constraints", "jacobian", "hessian"])
def test_an_exception_in_a_callback_is_raised_after_ipopt_returns(where):
    with pytest.raises(RuntimeError, match=f"boom in {where}"):
        solve(Quadratic(fail_in=where))


@pytest.mark.parametrize("where", ["gradient", "constraints", "jacobian", "hessian"])
def test_a_wrong_sized_result_is_reported_by_name(where):
    with pytest.raises(ValueError, match=f"{where}: expected \\d+ values, found \\d+"):
        solve(Quadratic(wrong_size_in=where))


def test_options_are_checked():
    with pytest.raises(TypeError, match="IPOPT refused option no_such_option"):
        solve(Quadratic(), no_such_option=1)
    with pytest.raises(TypeError, match="unsupported option value type list"):
        solve(Quadratic(), tol=[1e-8])


def test_the_library_is_the_one_cyipopt_wheels_ships():
    path = library_path()
    assert path.is_file() and "ipopt" in path.name
