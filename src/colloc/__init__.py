"""colloc: identify the hidden parameters of closed-loop dynamic systems by direct collocation."""

from colloc import transcription
from colloc.control import StateFeedback
from colloc.model import Model, ModelError, ProblemDefinitionError
from colloc.nlp import IntegralCost, Problem, Solution, TerminalCost, Tracking

__version__ = "0.1.0"

__all__ = [
    "IntegralCost",
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
