"""Excitation signals (sums of sines) and sensor noise for generating measurement data."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["SumOfSines", "add_sensor_noise", "random_phases", "seed_frequencies", "sum_of_sines"]

ArrayLike = npt.ArrayLike
Array = npt.NDArray[np.float64]

# The seed's excitation repeats every 240 s; each sine makes a whole number of cycles in that
# window, and the counts share no common factor so that no sine is a harmonic of another.
_SEED_CYCLES = (7, 11, 16, 25, 38, 61, 103, 131, 151, 181, 313, 523)
_SEED_PERIOD = 240.0


def seed_frequencies() -> Array:
    """The seed's 12 excitation frequencies ``2 pi [7, 11, ..., 523] / 240`` in rad/s."""
    return 2.0 * np.pi * np.asarray(_SEED_CYCLES, dtype=float) / _SEED_PERIOD


def random_phases(num: int, seed: int | None) -> Array:
    """``num`` phases drawn uniformly from ``[0, 2 pi)`` with ``numpy.random.default_rng(seed)``.

    Raises
    ------
    ValueError
        When ``num`` is not a non-negative integer.
    """
    if isinstance(num, bool) or not isinstance(num, int | np.integer) or num < 0:
        raise ValueError(f"num: expected an integer >= 0, found {num!r}")
    return np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, size=int(num))


def sum_of_sines(
    times: ArrayLike, frequencies: ArrayLike, amplitudes: ArrayLike, phases: ArrayLike
) -> Array:
    """Evaluate ``sum_j a_j sin(w_j t + phi_j)``.

    Parameters
    ----------
    times : array_like
        Times [s], any shape.
    frequencies, amplitudes, phases : array_like
        1-D arrays of equal length (rad/s, signal units, rad).

    Returns
    -------
    numpy.ndarray
        The signal, with the shape of ``times``.
    """
    w, a, phi = _sine_components(frequencies, amplitudes, phases)
    t = np.asarray(times, dtype=float)
    return np.sin(t[..., None] * w + phi) @ a


def _sine_components(
    frequencies: ArrayLike, amplitudes: ArrayLike, phases: ArrayLike
) -> tuple[Array, Array, Array]:
    arrays = {
        "frequencies": np.asarray(frequencies, dtype=float),
        "amplitudes": np.asarray(amplitudes, dtype=float),
        "phases": np.asarray(phases, dtype=float),
    }
    problems = [f"{k} must be 1-D, found shape {v.shape}" for k, v in arrays.items() if v.ndim != 1]
    problems += [f"{k} must be finite" for k, v in arrays.items() if not np.all(np.isfinite(v))]
    lengths = {k: v.size for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        problems.append(
            f"frequencies, amplitudes and phases must have equal length, found {lengths}"
        )
    if problems:
        raise ValueError("sum of sines: " + "; ".join(problems))
    return arrays["frequencies"], arrays["amplitudes"], arrays["phases"]


@dataclass(frozen=True, eq=False)
class SumOfSines:
    """A sum of sines ``F(t) = sum_j a_j sin(w_j t + phi_j)`` usable as a known input.

    Attributes
    ----------
    frequencies : numpy.ndarray
        Angular frequencies ``w_j`` [rad/s].
    amplitudes : numpy.ndarray
        Amplitudes ``a_j``.
    phases : numpy.ndarray
        Phases ``phi_j`` [rad].
    """

    frequencies: Array
    amplitudes: Array
    phases: Array

    def __post_init__(self) -> None:
        w, a, phi = _sine_components(self.frequencies, self.amplitudes, self.phases)
        object.__setattr__(self, "frequencies", w)
        object.__setattr__(self, "amplitudes", a)
        object.__setattr__(self, "phases", phi)

    def __call__(self, t: ArrayLike) -> Any:
        """The signal at ``t`` (a float for scalar ``t``, else an array shaped like ``t``)."""
        if isinstance(t, float | int):
            # The integrator calls this once per step with a float; skip array dispatch.
            return float(np.dot(self.amplitudes, np.sin(self.frequencies * t + self.phases)))
        return sum_of_sines(t, self.frequencies, self.amplitudes, self.phases)

    @classmethod
    def from_seed(cls, amplitude: ArrayLike, seed: int | None) -> SumOfSines:
        """The seed's 12 frequencies with seeded uniform random phases in ``[0, 2 pi)``.

        Parameters
        ----------
        amplitude : float or array_like of length 12
            Amplitude of every sine (a scalar is used for all twelve).
        seed : int or None
            Seed of ``numpy.random.default_rng`` for the phases.
        """
        w = seed_frequencies()
        a = np.broadcast_to(np.asarray(amplitude, dtype=float), w.shape).copy()
        return cls(w, a, random_phases(w.size, seed))


# --------------------------------------------------------------------------------------------
# Noise


def add_sensor_noise(array: ArrayLike, std: ArrayLike, seed: int | None) -> Array:
    """Return ``array`` plus zero-mean Gaussian noise.

    Parameters
    ----------
    array : array_like
        Clean measurements, 1-D (one signal) or 2-D (samples x signals).
    std : float or array_like
        Standard deviation: one for all, or one per column of a 2-D ``array``.
    seed : int or None
        Seed of ``numpy.random.default_rng``.

    Returns
    -------
    numpy.ndarray
        A new array; ``array`` is not modified.
    """
    y = np.asarray(array, dtype=float)
    s = np.asarray(std, dtype=float)
    problems = []
    if y.ndim not in (1, 2):
        problems.append(f"array must be 1-D or 2-D, found shape {y.shape}")
    if s.ndim > 1 or (s.ndim == 1 and (y.ndim != 2 or s.size != y.shape[-1])):
        problems.append(
            f"std must be a scalar or have one entry per column of array (shape {y.shape}), "
            f"found shape {s.shape}"
        )
    if not np.all(np.isfinite(s)) or np.any(s < 0):
        problems.append(f"std must be finite and >= 0, found {s}")
    if problems:
        raise ValueError("add_sensor_noise: " + "; ".join(problems))
    return y + np.random.default_rng(seed).standard_normal(y.shape) * s


@dataclass(frozen=True)
class SampledNoise:
    """Gaussian white noise drawn at sample times, linear between them (process noise).

    Drawn once per sample with standard deviation ``std`` and interpolated linearly, so a
    simulation driven by it and a collocation grid on the same samples see the same signal
    (the midpoint scheme's average of two nodes is the interval's mean).

    Parameters
    ----------
    times : ndarray
        Increasing sample times.
    values : ndarray
        The noise at those times.
    """

    times: Array
    values: Array

    def __call__(self, t: ArrayLike) -> Any:
        """The noise at ``t`` (held at the end values outside the samples)."""
        return np.interp(np.asarray(t, dtype=float), self.times, self.values)

    @classmethod
    def draw(cls, times: ArrayLike, std: float, seed: int | None) -> SampledNoise:
        """Draw one realisation.

        Parameters
        ----------
        times : array_like
            Sample times, strictly increasing.
        std : float
            Standard deviation per sample, >= 0.
        seed : int or None
            Seed of ``numpy.random.default_rng``.

        Returns
        -------
        SampledNoise
        """
        t = np.asarray(times, dtype=float)
        if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
            raise ValueError("times: expected at least 2 strictly increasing sample times")
        if not (np.isfinite(std) and std >= 0):
            raise ValueError(f"std: expected a finite number >= 0, found {std!r}")
        rng = np.random.default_rng(seed)
        return cls(t, rng.normal(0.0, float(std), t.size))
