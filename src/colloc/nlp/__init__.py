"""The collocation problem, its layout, objective terms and solution."""

from colloc.nlp.known import KnownTrajectory
from colloc.nlp.layout import Layout
from colloc.nlp.objective import IntegralCost, ParameterPrior, TerminalCost, Tracking
from colloc.nlp.problem import Problem
from colloc.nlp.solution import Solution
from colloc.nlp.trials import Trials, TrialsSolution

__all__ = [
    "IntegralCost",
    "KnownTrajectory",
    "Layout",
    "ParameterPrior",
    "Problem",
    "Solution",
    "TerminalCost",
    "Tracking",
    "Trials",
    "TrialsSolution",
]
