"""The intermediate model form ``F(x', x, r, p, t) = 0`` and its construction."""

from colloc.model.errors import ModelError, ProblemDefinitionError
from colloc.model.model import Model

__all__ = ["Model", "ModelError", "ProblemDefinitionError"]
