"""Initial guesses for feedback gains, by the names the command line uses (``-i``)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: ``guess(known_gains, rng, direct) -> gains``; ``direct()`` runs direct identification.
GainGuess = Callable[[np.ndarray, np.random.Generator, Callable[[], np.ndarray]], np.ndarray]


def _known(
    known: np.ndarray, rng: np.random.Generator, direct: Callable[[], np.ndarray]
) -> np.ndarray:
    return known.copy()


def _zero(
    known: np.ndarray, rng: np.random.Generator, direct: Callable[[], np.ndarray]
) -> np.ndarray:
    return np.zeros_like(known)


def _ones(
    known: np.ndarray, rng: np.random.Generator, direct: Callable[[], np.ndarray]
) -> np.ndarray:
    return np.ones_like(known)


def _close(
    known: np.ndarray, rng: np.random.Generator, direct: Callable[[], np.ndarray]
) -> np.ndarray:
    return known + 0.5 * np.abs(known) * rng.standard_normal(known.shape)


def _random(
    known: np.ndarray, rng: np.random.Generator, direct: Callable[[], np.ndarray]
) -> np.ndarray:
    return 100.0 * rng.standard_normal(known.shape)


def _direct(
    known: np.ndarray, rng: np.random.Generator, direct: Callable[[], np.ndarray]
) -> np.ndarray:
    return direct()


GAIN_GUESSES: dict[str, GainGuess] = {
    "known": _known,
    "zero": _zero,
    "ones": _ones,
    "close": _close,
    "random": _random,
    "direct": _direct,
}
"""The ``-i`` choices: known = the truth; close = K + 0.5|K| N(0, 1); random = 100 N(0, 1);
direct = least squares of the equations of motion on smoothed measurements."""
