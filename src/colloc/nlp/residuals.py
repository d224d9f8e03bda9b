"""The residuals of the tracking terms at a point, and diagnostics of the noise model.

Every least-squares term of the objective (a :class:`colloc.Tracking`, the penalty of a
problem's ``process_noise``, the tracking of its ``measured_inputs``) is a sum of
``w_jk (y_j(z_k) - d_jk)^2``. Its residuals ``y_j - d_j`` are recovered from the built
objective itself, evaluated twice per signal with the other terms and signals switched off
and the measurement shifted by one: ``(y - d)^2 - (y - d - 1)^2 = 2 (y - d) - 1``. No second
model of the outputs is built, so what is diagnosed is exactly what was fitted.

If the noise model is right, the weighted residuals ``sqrt(w) r`` of each tracked signal
are white with unit variance (times the reference variance of relative weights). Their
lag-1 autocorrelation says whether they are white (process noise left out of the model makes
tracking residuals slow and strongly correlated); their root mean square against the
assumed standard deviation says whether the noise levels are right. An estimated
disturbance (and a measured input's correction) is smoothed and shrunk by its prior, so it
is only checked for being larger than its assumed standard deviation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from scipy import stats

from colloc.nlp.assembly import AssembledNLP
from colloc.nlp.objective import NodeTerm


class LeastSquaresProblem(Protocol):
    """What the residuals are read from: a built problem's NLP and objective terms (a
    :class:`colloc.Problem` is one). Its own measured-input and process-noise terms are the
    last of ``node_terms``, in that order."""

    @property
    def nlp(self) -> AssembledNLP: ...  # noqa: D102
    @property
    def node_terms(self) -> Sequence[NodeTerm]: ...  # noqa: D102
    @property
    def measured_inputs(self) -> Mapping[Any, Any]: ...  # noqa: D102
    @property
    def process_noise(self) -> Mapping[Any, Any]: ...  # noqa: D102


#: Lag-1 autocorrelations outside which residuals are reported as not white: above, slow
#: residuals (a disturbance the model misses); below, alternating ones (the process noise
#: allowed lets the states follow the measurement noise; a right process-noise model
#: already gives somewhat negative values, about -0.25 on a mass-spring-damper).
CORRELATION_LIMITS = (-0.4, 0.2)
#: Root mean square of the residuals against the assumed standard deviation outside which
#: the noise level is reported as wrong.
SIZE_LIMITS = (0.5, 2.0)
#: Lags of the Ljung-Box test of whiteness.
LJUNG_BOX_LAGS = 10
#: Lag-1 autocorrelation of a tracked signal's residuals above which a solution's status says
#: the fit leaves a systematic misfit (well above :data:`CORRELATION_LIMITS`' 0.2, which only
#: questions the KKT standard errors).
SYSTEMATIC_LIMIT = 0.5


@dataclass(frozen=True)
class SignalResiduals:
    """Residuals of one tracked signal.

    Attributes
    ----------
    name : str
        The tracked output or input.
    term : int
        Index of its least-squares term in the problem's objective (the problem's own
        measured-input and process-noise terms come after the user's terms).
    residuals : ndarray, shape (N,)
        ``y - d`` at every node, NaN where the sample was left out (weight 0).
    weights : ndarray, shape (N,)
        Each sample's weight in the objective: the signal's weight times the term's
        quadrature factor (1 for a plain sum).
    kind : str
        ``"tracking"``, ``"measured input"`` (a problem's ``measured_inputs``) or
        ``"process noise"`` (an estimated disturbance, whose residual is the disturbance
        itself).
    """

    name: str
    term: int
    residuals: np.ndarray
    weights: np.ndarray
    kind: str = "tracking"


@dataclass(frozen=True)
class SignalDiagnostics:
    """Size and whiteness of one signal's residuals.

    Attributes
    ----------
    name : str
    kind : str
        As :attr:`SignalResiduals.kind`.
    samples : int
    rms : float
        Root mean square of the residuals.
    assumed_std : float
        ``sqrt(reference_variance / w)`` (the median weight of the signal).
    size_ratio : float
        ``rms / assumed_std``: about 1 when the noise level is right.
    autocorrelation : float
        Lag-1 autocorrelation of the residuals: about 0 when they are white.
    ljung_box_p : float
        p-value of the Ljung-Box test of whiteness over :data:`LJUNG_BOX_LAGS` lags.
    """

    name: str
    kind: str
    samples: int
    rms: float
    assumed_std: float
    size_ratio: float
    autocorrelation: float
    ljung_box_p: float


@dataclass(frozen=True)
class ResidualDiagnostics:
    """Per-signal diagnostics and the warnings they raise.

    Attributes
    ----------
    signals : tuple of SignalDiagnostics
    warnings : tuple of str
        One sentence per signal whose residuals are not white or not of the assumed size.
    """

    signals: tuple[SignalDiagnostics, ...]
    warnings: tuple[str, ...]

    def as_dict(self) -> dict[str, object]:
        """Plain values for JSON and result records."""
        return {
            "signals": [vars(s).copy() for s in self.signals],
            "warnings": list(self.warnings),
        }


def tracking_residuals(
    problem: LeastSquaresProblem, z: np.ndarray, kind: str | None = None
) -> list[SignalResiduals]:
    """The residuals of every signal of every least-squares term of ``problem`` at ``z``.

    Parameters
    ----------
    problem : Problem
        Or anything holding its NLP and objective terms (:class:`LeastSquaresProblem`).
    z : ndarray
        A free vector, e.g. ``solution.z``.
    kind : str, optional
        Only the signals of this kind (``"tracking"``, ``"measured input"``, ``"process
        noise"``, ``"parameter prior"``); the others are not evaluated.

    Returns
    -------
    list of SignalResiduals
        In the order of the terms and of their signals.
    """
    placement = problem.nlp.objective_placement
    if placement is None or not problem.node_terms:
        return []
    z = np.asarray(z, dtype=float)
    if z.shape != (problem.nlp.n,):
        raise ValueError(f"z: expected shape ({problem.nlp.n},), found {z.shape}")
    local = placement.gather(z)
    terms = problem.node_terms
    kinds = [term.kind for term in terms]
    own = (["measured input"] if problem.measured_inputs else []) + (
        ["process noise"] if problem.process_noise else []
    )
    kinds[len(terms) - len(own) :] = own
    out = []
    for cols in signal_columns(problem):
        if kind is not None and kinds[cols.term] != kind:
            continue
        weights = placement.data[:, cols.weight] * terms[cols.term].factors
        data = cols.alone(placement.data, weight=1.0, factor=1.0)
        v0 = placement.mapped.values(local, data).ravel()
        data[:, cols.measurement] += 1.0
        v1 = placement.mapped.values(local, data).ravel()
        r = 0.5 * (v0 - v1 + 1.0)
        out.append(
            SignalResiduals(
                cols.name, cols.term, np.where(weights > 0, r, np.nan), weights, kinds[cols.term]
            )
        )
    return out


@dataclass(frozen=True)
class SignalColumns:
    """Where one signal of a least-squares term sits in the objective placement's data.

    Attributes
    ----------
    term : int
        Index of the term in ``problem.node_terms``.
    name : str
    measurement, weight, factor : int
        Columns of its measurements, its weights and its term's quadrature factors.
    switches : ndarray
        Every term's factor column and this term's weight columns: zeroing them and
        restoring ``weight`` and ``factor`` leaves this signal alone in the objective.
    """

    term: int
    name: str
    measurement: int
    weight: int
    factor: int
    switches: np.ndarray

    def alone(
        self, data: np.ndarray, weight: float | None = None, factor: float | None = None
    ) -> np.ndarray:
        """A copy of ``data`` in which only this signal counts, with its own weights and
        factors or the constants given."""
        out = data.copy()
        out[:, self.switches] = 0.0
        out[:, self.weight] = data[:, self.weight] if weight is None else weight
        out[:, self.factor] = data[:, self.factor] if factor is None else factor
        return out


def signal_columns(problem: LeastSquaresProblem) -> list[SignalColumns]:
    """The columns of every signal of every least-squares term, in the order of
    :func:`tracking_residuals`.

    The objective placement's data hold the node data, then each term's data (a tracking
    term of ``m`` signals: ``m`` measurement then ``m`` weight columns), then one factor
    column per term, then the Gauss-Newton switch.

    Parameters
    ----------
    problem : Problem
        Or anything holding its NLP and objective terms (:class:`LeastSquaresProblem`).

    Returns
    -------
    list of SignalColumns
    """
    placement = problem.nlp.objective_placement
    terms = problem.node_terms
    if placement is None or not terms:
        return []
    widths = [t.data.shape[1] for t in terms]
    offset = placement.data.shape[1] - sum(widths) - len(terms) - 1
    factors = offset + sum(widths) + np.arange(len(terms))
    out = []
    for i, term in enumerate(terms):
        m = len(term.signals)
        switches = np.r_[factors, offset + m : offset + 2 * m]
        out += [
            SignalColumns(i, name, offset + j, offset + m + j, int(factors[i]), switches)
            for j, name in enumerate(term.signals)
        ]
        offset += widths[i]
    return out


def residual_diagnostics(
    problem: LeastSquaresProblem, z: np.ndarray, reference_variance: float = 1.0
) -> ResidualDiagnostics:
    """Whiteness and size of the residuals of every tracked signal at ``z``.

    Parameters
    ----------
    problem : Problem
        Or anything holding its NLP and objective terms (:class:`LeastSquaresProblem`).
    z : ndarray
        Usually ``solution.z``.
    reference_variance : float
        The noise variance per unit weight: 1 when the weights are ``1 / sigma^2``; the
        reference variance when they are relative to one (e.g. all weights 1 and every
        signal's noise of standard deviation ``sigma``: ``sigma**2``).

    Returns
    -------
    ResidualDiagnostics
    """
    if not (np.isfinite(reference_variance) and reference_variance > 0):
        raise ValueError(f"reference_variance: expected a number > 0, found {reference_variance!r}")
    signals, warnings = [], []
    for s in tracking_residuals(problem, z):
        r = s.residuals[np.isfinite(s.residuals)]
        if r.size < 3:
            continue
        rms = float(np.sqrt(np.mean(r**2)))
        assumed = float(np.sqrt(reference_variance / np.median(s.weights[s.weights > 0])))
        centred = r - r.mean()
        acf = _autocorrelation(centred, LJUNG_BOX_LAGS)
        n = r.size
        lags = np.arange(1, acf.size + 1)
        q = n * (n + 2) * float(np.sum(acf**2 / (n - lags)))
        p = float(stats.chi2.sf(q, acf.size)) if acf.size else 1.0
        d = SignalDiagnostics(
            s.name,
            s.kind,
            int(n),
            rms,
            assumed,
            rms / assumed,
            float(acf[0]) if acf.size else 0.0,
            p,
        )
        signals.append(d)
        if s.kind != "tracking":
            # a maximum a posteriori disturbance (or a measured input's correction, which
            # acts as one) is smoothed and shrunk towards zero, what the data cannot see of
            # it staying at 0: only one larger than assumed is wrong
            if d.size_ratio > SIZE_LIMITS[1]:
                warnings.append(
                    f"{s.name}: estimated {s.kind} error has rms {rms:.3g}, "
                    f"{d.size_ratio:.2f} times the standard deviation {assumed:.3g} given for "
                    "it; give a larger one"
                )
            continue
        if d.autocorrelation > CORRELATION_LIMITS[1]:
            warnings.append(
                f"{s.name}: residuals are not white (lag-1 autocorrelation "
                f"{d.autocorrelation:.2f}); the model misses a disturbance or the noise is "
                "coloured, so KKT standard errors are too small: use the robust ones "
                "(autoregressive or sandwich) or model process noise"
            )
        elif d.autocorrelation < CORRELATION_LIMITS[0]:
            warnings.append(
                f"{s.name}: residuals alternate (lag-1 autocorrelation "
                f"{d.autocorrelation:.2f}); the states follow the measurement noise: the "
                "process noise given is too large"
            )
        if not SIZE_LIMITS[0] <= d.size_ratio <= SIZE_LIMITS[1]:
            warnings.append(
                f"{s.name}: residuals have rms {rms:.3g} where the weights assume a standard "
                f"deviation of {assumed:.3g} ({d.size_ratio:.2f} times); the noise level given "
                "for it is wrong"
            )
    return ResidualDiagnostics(tuple(signals), tuple(warnings))


def systematic_misfit(problem: LeastSquaresProblem, z: np.ndarray) -> list[str]:
    """Notes for the tracked signals whose residuals at ``z`` are systematic, not noise.

    A fit that stopped at a worse local optimum, or whose model misses a disturbance, leaves
    slow residuals (lag-1 autocorrelation above :data:`SYSTEMATIC_LIMIT`); white measurement
    noise leaves none. Noise-free data show the scheme's own error this way. The residuals
    cannot tell those causes apart (on the gallery's exact fits at the global optimum they
    fired every time); :func:`colloc.other_starts` can.

    Parameters
    ----------
    problem : Problem
        Or anything holding its NLP and objective terms (:class:`LeastSquaresProblem`).
    z : ndarray

    Returns
    -------
    list of str
        One note per such signal (empty when none).
    """
    notes = []
    for s in tracking_residuals(problem, z, kind="tracking"):
        r = s.residuals[np.isfinite(s.residuals)]
        if r.size < 20:
            continue
        lag1 = float(_autocorrelation(r - r.mean(), 1)[0])
        if lag1 > SYSTEMATIC_LIMIT:
            notes.append(
                f"tracking residuals of {s.name} are systematic, not noise (lag-1 "
                f"autocorrelation {lag1:.2f}): a disturbance the model misses, noise-free "
                "data, or a worse local optimum, which colloc.other_starts tells apart"
            )
    return notes


def _autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation at lags 1..max_lag (fewer for short series)."""
    lags = min(max_lag, x.size - 1)
    denom = float(x @ x)
    if denom == 0.0:
        return np.zeros(lags)
    return np.array([float(x[:-k] @ x[k:]) / denom for k in range(1, lags + 1)])
