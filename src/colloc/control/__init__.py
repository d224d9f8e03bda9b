"""Controllers that close a model's loop symbolically, and LQR design."""

from colloc.control.gain_scheduled import GainScheduled, joint_isolated_mask
from colloc.control.lqr import LQRResult, lqr
from colloc.control.state_feedback import StateFeedback, gain_symbols

__all__ = [
    "GainScheduled",
    "LQRResult",
    "StateFeedback",
    "gain_symbols",
    "joint_isolated_mask",
    "lqr",
]
