"""The SymPy -> CasADi bridge, per-item derivatives and the on-disk build cache."""

from colloc.numeric.bridge import UnsupportedExpressionError, sympy_to_casadi
from colloc.numeric.cache import BuildCache
from colloc.numeric.stencil import StencilFunctions

__all__ = ["BuildCache", "StencilFunctions", "UnsupportedExpressionError", "sympy_to_casadi"]
