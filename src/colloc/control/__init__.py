"""Controllers that close a model's loop symbolically."""

from colloc.control.state_feedback import StateFeedback, gain_symbols

__all__ = ["StateFeedback", "gain_symbols"]
