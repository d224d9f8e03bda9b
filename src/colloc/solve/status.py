"""IPOPT return codes, with what they mean and what to try."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class SolveStatus:
    """The outcome of a solve.

    Attributes
    ----------
    code : int
        IPOPT's ApplicationReturnStatus.
    name : str
    success : bool
        True for an optimum (or one acceptable to IPOPT's relaxed tolerances).
    hint : str
        What to try when it failed (empty on success).
    at_bounds : tuple of str
        Names of the unknown parameters that ended at one of their bounds: an optimum
        there is the bound's, not the data's (widen the bound, or check the model).
    """

    code: int
    name: str
    success: bool
    hint: str
    at_bounds: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def reliable(self) -> bool:
        """Whether the result is an estimate to use as one: an optimum (``success``) with no
        parameter held by a bound (``at_bounds`` empty)."""
        return self.success and not self.at_bounds

    def __str__(self) -> str:
        text = f"{self.name} ({self.code})"
        text = text if not self.hint else f"{text}: {self.hint}"
        if self.at_bounds:
            text += (
                f"; parameters at their bounds: {list(self.at_bounds)} (the optimum is the "
                "bound's, not the data's: widen the bounds or check the model)"
            )
        for note in self.notes:
            text += f"; {note}"
        return text


_STATUS: dict[int, tuple[str, bool, str]] = {
    0: ("Solve_Succeeded", True, ""),
    1: (
        "Solved_To_Acceptable_Level",
        True,
        "converged only to IPOPT's acceptable tolerances; check the result or tighten 'tol'",
    ),
    2: (
        "Infeasible_Problem_Detected",
        False,
        "the constraints cannot all hold: check instance constraints, bounds and that the data "
        "fit the model (units, signs, sample times)",
    ),
    3: (
        "Search_Direction_Becomes_Too_Small",
        False,
        "progress stalled; scale the problem (tracking weights, units) or relax 'tol'",
    ),
    4: (
        "Diverging_Iterates",
        False,
        "variables grew without bound; add bounds on states or parameters",
    ),
    5: ("User_Requested_Stop", False, "stopped by the progress callback"),
    6: ("Feasible_Point_Found", True, ""),
    -1: (
        "Maximum_Iterations_Exceeded",
        False,
        "raise max_iter, or start closer: a better initial guess (e.g. gains from "
        "colloc.identify.fit_gain_schedule, or the pendulum study's -i direct) or "
        "the exact Hessian instead of limited-memory",
    ),
    -2: (
        "Restoration_Failed",
        False,
        "IPOPT could not regain feasibility: start from states that satisfy the dynamics better "
        "(e.g. measured or simulated trajectories) or loosen bounds",
    ),
    -3: (
        "Error_In_Step_Computation",
        False,
        "the KKT system is singular: check that every unknown affects the problem (unused "
        "parameters are unidentifiable) and that the model is not degenerate",
    ),
    -4: ("Maximum_CpuTime_Exceeded", False, "raise max_cpu_time or shorten the data"),
    -5: ("Maximum_WallTime_Exceeded", False, "raise max_wall_time or shorten the data"),
    -10: (
        "Not_Enough_Degrees_Of_Freedom",
        False,
        "more equality constraints than unknowns: remove redundant instance constraints",
    ),
    -11: ("Invalid_Problem_Definition", False, "the bounds are inconsistent (lower > upper?)"),
    -12: ("Invalid_Option", False, "an IPOPT option name or value is wrong; see the log"),
    -13: (
        "Invalid_Number_Detected",
        False,
        "NaN or inf in a function value or derivative: check the initial guess and that "
        "expressions are defined there (sqrt, log, division)",
    ),
    -100: ("Unrecoverable_Exception", False, "IPOPT failed internally; see the log"),
    -101: ("NonIpopt_Exception_Thrown", False, "a callback raised an exception; see the log"),
    -102: ("Insufficient_Memory", False, "use fewer nodes or limited-memory Hessian"),
    -199: ("Internal_Error", False, "IPOPT failed internally; see the log"),
}


def status_from_code(code: int) -> SolveStatus:
    """The :class:`SolveStatus` for an IPOPT return code."""
    name, success, hint = _STATUS.get(code, (f"Unknown_Status_{code}", False, "see the log"))
    return SolveStatus(code, name, success, hint)
