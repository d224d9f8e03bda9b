"""colloc: identify the hidden parameters of closed-loop dynamic systems by direct collocation.

The public names below load on first use (``colloc._lazy``): ``import colloc`` costs
milliseconds, and SymPy, CasADi and SciPy are imported by the first name that needs them.
"""

# ruff: noqa: F401  (the TYPE_CHECKING imports are re-exported by __all__, built from _EXPORTS)
from typing import TYPE_CHECKING

from colloc._lazy import lazy_exports

__version__ = "0.1.0"

_EXPORTS = {
    "GainScheduled": "colloc.control",
    "StateFeedback": "colloc.control",
    "LQRResult": "colloc.control.lqr",
    "lqr": "colloc.control.lqr",
    "Model": "colloc.model",
    "ModelError": "colloc.model",
    "ProblemDefinitionError": "colloc.model",
    "linearize": "colloc.model.linearize",
    "StateSpace": "colloc.model.state_space",
    "IntegralCost": "colloc.nlp",
    "KnownTrajectory": "colloc.nlp",
    "ParameterPrior": "colloc.nlp",
    "Problem": "colloc.nlp",
    "Solution": "colloc.nlp",
    "TerminalCost": "colloc.nlp",
    "Tracking": "colloc.nlp",
    "Trials": "colloc.nlp",
    "TrialsSolution": "colloc.nlp",
    "ResidualDiagnostics": "colloc.nlp.residuals",
    "residual_diagnostics": "colloc.nlp.residuals",
    "DiscretisationError": "colloc.nlp.refinement",
    "discretisation_error": "colloc.nlp.refinement",
    "refined_problem": "colloc.nlp.refinement",
    "StartsReport": "colloc.nlp.starts",
    "other_starts": "colloc.nlp.starts",
    "MarginalCorrection": "colloc.nlp.marginal",
    "marginal_correction": "colloc.nlp.marginal",
    "DiscretisationWarning": "colloc.nlp.uncertainty",
    "ParameterUncertainty": "colloc.nlp.uncertainty",
    "cramer_rao_bound": "colloc.nlp.uncertainty",
    "parameter_uncertainty": "colloc.nlp.uncertainty",
    "GaussNewtonOptions": "colloc.solve.gauss_newton",
    "transcription": "colloc.transcription",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

if TYPE_CHECKING:  # for type checkers; re-exported through __all__
    from colloc import transcription
    from colloc.control import GainScheduled, StateFeedback
    from colloc.control.lqr import LQRResult, lqr
    from colloc.model import Model, ModelError, ProblemDefinitionError
    from colloc.model.linearize import linearize
    from colloc.model.state_space import StateSpace
    from colloc.nlp import (
        IntegralCost,
        KnownTrajectory,
        ParameterPrior,
        Problem,
        Solution,
        TerminalCost,
        Tracking,
        Trials,
        TrialsSolution,
    )
    from colloc.nlp.marginal import MarginalCorrection, marginal_correction
    from colloc.nlp.refinement import (
        DiscretisationError,
        discretisation_error,
        refined_problem,
    )
    from colloc.nlp.residuals import ResidualDiagnostics, residual_diagnostics
    from colloc.nlp.starts import StartsReport, other_starts
    from colloc.nlp.uncertainty import (
        DiscretisationWarning,
        ParameterUncertainty,
        cramer_rao_bound,
        parameter_uncertainty,
    )
    from colloc.solve.gauss_newton import GaussNewtonOptions

__all__ = [*_EXPORTS, "__version__"]
