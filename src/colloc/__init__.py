"""colloc: identify the hidden parameters of closed-loop dynamic systems by direct collocation."""

from colloc import transcription
from colloc.control import GainScheduled, StateFeedback
from colloc.control.lqr import LQRResult, lqr
from colloc.model import Model, ModelError, ProblemDefinitionError
from colloc.model.linearize import linearize
from colloc.model.state_space import StateSpace
from colloc.nlp import IntegralCost, Problem, Solution, TerminalCost, Tracking
from colloc.nlp.uncertainty import ParameterUncertainty, cramer_rao_bound, parameter_uncertainty
from colloc.solve.gauss_newton import GaussNewtonOptions

__version__ = "0.1.0"

__all__ = [
    "GainScheduled",
    "GaussNewtonOptions",
    "IntegralCost",
    "LQRResult",
    "ParameterUncertainty",
    "StateSpace",
    "linearize",
    "lqr",
    "parameter_uncertainty",
    "cramer_rao_bound",
    "Model",
    "ModelError",
    "Problem",
    "ProblemDefinitionError",
    "Solution",
    "StateFeedback",
    "TerminalCost",
    "Tracking",
    "__version__",
    "transcription",
]
