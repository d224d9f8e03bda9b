"""Solvers (IPOPT, constrained Gauss-Newton), their results and status codes."""

from colloc.solve.gauss_newton import ChainStructure, GaussNewtonOptions, solve_gauss_newton
from colloc.solve.ipopt import solve_nlp
from colloc.solve.result import SolveResult
from colloc.solve.status import SolveStatus, status_from_code
from colloc.solve.watchdog import SolverStalled

__all__ = [
    "ChainStructure",
    "GaussNewtonOptions",
    "SolveResult",
    "SolveStatus",
    "SolverStalled",
    "solve_gauss_newton",
    "solve_nlp",
    "status_from_code",
]
