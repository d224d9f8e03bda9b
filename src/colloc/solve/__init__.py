"""IPOPT driving, progress and status codes."""

from colloc.solve.ipopt import IpoptResult, solve_nlp
from colloc.solve.status import SolveStatus, status_from_code

__all__ = ["IpoptResult", "SolveStatus", "solve_nlp", "status_from_code"]
