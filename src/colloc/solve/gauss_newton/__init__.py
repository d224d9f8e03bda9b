"""Constrained Gauss-Newton for one-step collocation with many global parameters.

For an NLP ``min f(z) s.t. c(z) = 0`` whose variables are states ``x_k`` at nodes
``k = 0..N-1`` plus ``q`` global parameters ``theta``, and whose constraints are one block of
``n`` defects per interval linking ``x_k``, ``x_{k+1}`` and ``theta`` (backward Euler,
midpoint), each step solves the Gauss-Newton model (the objective's Hessian; the constraints'
curvature is left out) with the linearized defects eliminated by *condensing*: within a
segment of nodes the state step is propagated forward,

    dx_{k+1} = -E_k^{-1} (D_k dx_k + T_k dtheta + c_k),

so each segment contributes a dense block in its first state and ``theta`` only, and the
segments are joined by the linearized defects at their boundaries. The reduced system has
``n * segments + q`` unknowns, so the cost per iteration grows linearly in ``N`` (where a
general sparse LDL^T of the KKT matrix fills the parameter block in at every node) and each
segment can be checked against a wall-time limit or interrupted without losing the last
accepted iterate. The step is damped (Levenberg-Marquardt on the reduced Hessian) and
globalised by a backtracking line search on the l1 merit ``f + mu sum_k ||E_k^{-1} c_k||_1``
(defects measured as corrections of the next state, with ``E_k`` frozen at the iterate).

The objective is a sum of terms each in one node's states and the parameters (tracked
states, and tracked controller outputs such as joint torques ``T*(phi) - K(phi) s``). Its
Hessian is the NLP's Gauss-Newton one (tracking terms by ``2 J^T W J``), with each node's
state block also taken positive semidefinite for any other term; the node-parameter and
parameter blocks enter the reduced system as they are.

This is the classical approach to parameter estimation in ODEs by collocation or multiple
shooting (Bock's generalized Gauss-Newton with condensing); the implementation is ours.

The package's modules: :mod:`~colloc.solve.gauss_newton.structure` (the chain and its blocks),
:mod:`~colloc.solve.gauss_newton.condensing` (condense, expand, the adjoint),
:mod:`~colloc.solve.gauss_newton.banded` (the reduced system's banded solve) and
:mod:`~colloc.solve.gauss_newton.solver` (damping, line search, stops).
"""

from colloc.solve.gauss_newton.solver import GaussNewtonOptions, solve_gauss_newton
from colloc.solve.gauss_newton.structure import ChainStructure

__all__ = ["ChainStructure", "GaussNewtonOptions", "solve_gauss_newton"]
