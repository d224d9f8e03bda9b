"""Error types raised when a user's model, data or options are not usable."""

from __future__ import annotations

from collections.abc import Iterable


class ModelError(ValueError):
    """A model definition has one or more problems.

    All problems found are reported at once in ``problems`` and in the message, so a user
    can fix them in one pass instead of meeting them one at a time.
    """

    def __init__(self, problems: Iterable[str], what: str = "model") -> None:
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"the {what} has {len(self.problems)} problem(s):\n{lines}")


class ProblemDefinitionError(ModelError):
    """The collocation problem (grid, data, unknowns, bounds, ...) is not consistent."""

    def __init__(self, problems: Iterable[str]) -> None:
        super().__init__(problems, what="collocation problem")


def raise_if_any(problems: list[str], error: type[ModelError] = ModelError) -> None:
    """Raise ``error`` listing ``problems`` when the list is not empty."""
    if problems:
        raise error(problems)
