"""The gait smoother's settings, and the figures measured that set their defaults."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from colloc.transcription.base import Scheme
from colloc.transcription.midpoint import Midpoint

Progress = Callable[[str, str], None]

#: Slip scales [m/s] of the contact's friction law visited after the midpoint stage, from the
#: smoothed start value down; the model's own value is appended. Measured on 20 s of a noisy
#: trial: 4-10 iterations per step; straight from 0.1 to 0.01 diverged.
CONTINUATION: tuple[float, ...] = (0.05, 0.03, 0.02, 0.015)
#: Newton steps of the zero-defect start of a scheme with stage values inside the intervals,
#: which are nonlinear in them, and the largest defect they leave (Radau IIA on 20 s of a
#: noisy trial: 3.4e-9 after 20 steps, against the 1e-9 of the one-step schemes' start).
COMPLETION_STEPS, COMPLETION_TOL = 20, 1e-8
#: Slip scale [m/s] of the first two stages (what the gait2d authors use since 2026).
START_FRICTION_VELOCITY = 0.1
#: Standard deviation [N, N, N m] per sample of the residual forces on the trunk's x, y and
#: angle: large enough for the start's inverse dynamics, small enough that the fit removes
#: them where the joint torques can do the work.
RESIDUAL_STD: tuple[float, float, float] = (10.0, 10.0, 10.0)
#: IPOPT options of the smoother's solves. Without IPOPT's gradient-based scaling backward
#: Euler converged on 20 s of a noisy trial in 26 iterations; with it, it diverged
#: (regularisation 1e14, defects 1e3) from the same zero-defect start.
IPOPT_OPTIONS: dict[str, Any] = {"nlp_scaling_method": "none"}
#: A stage's solve is stopped as diverging once its objective exceeds this multiple of its
#: start's, or its dual infeasibility exceeds :data:`DIVERGED_DUAL_INFEASIBILITY`. Two
#: continuation steps from 0.015 to 0.01 m/s (27 s and 13 s windows of the seed-71 trial)
#: started at defects of 317 and 354, their objective rose 10-fold within 3 and 8
#: iterations and 70-1000-fold by the 14th, their dual infeasibility past 1e13, and the next
#: iteration's factorisation ran for minutes (over 15 in one case); a failed continuation
#: step is halved (0.0125, then 0.01 converged in 6 iterations each). A stop is recorded as
#: the stage's status ``User_Requested_Stop``.
DIVERGED_OBJECTIVE_FACTOR = 10.0
#: The iteration budget of the last stage at full weights, in continuation steps' budgets.
FULL_WEIGHTS_STEPS = 2
#: Output parameters estimated with the motion (``GaitSmoother(output_parameters=...)``):
#: the most passes of their update and the last stage's solve, and the change [their unit:
#: metres for markers' places] below which they are taken as settled.
PARAMETER_PASSES = 6
PARAMETER_TOL = 1e-4
#: The same guard for the second-order scheme's stage, warm-started from backward Euler's
#: nodes: its defects start large (30-90 on 4 s of a marker smoother, whose objective at
#: backward Euler's solution is the markers' noise alone), and its objective rose more than
#: 10-fold in the first iteration before the solve converged (15-190 iterations).
DIVERGED_OBJECTIVE_FACTOR_WARM_START = 1e3
DIVERGED_DUAL_INFEASIBILITY = 1e10


@dataclass(frozen=True)
class SmootherSettings:
    """What determines a smoother run.

    Attributes
    ----------
    cutoff_hz : float
        Cut-off of the zero-lag low-pass Butterworth filter of the start's positions.
    filter_order : int
        Order of that filter (applied forward and backward, so twice the attenuation).
    start_friction_velocity : float
        Contact slip scale ``v_s`` [m/s] of the backward-Euler and midpoint stages.
    continuation : tuple of float
        Intermediate slip scales of the continuation (decreasing, between the start value
        and the model's); the model's own value ends it.
    residual_std : tuple of float
        Standard deviations of the three trunk residual forces per sample.
    max_halvings : int
        How often a failed continuation step is halved before the smoother gives up.
    max_iter : int
        IPOPT iterations per stage.
    step_max_iter : int
        IPOPT iterations per continuation step: a step that needs more is halved (converged
        steps took 5-25; a 30 s window's last step was still iterating after 450 s).
    scheme : Scheme
        The scheme of the stages after backward Euler (default
        :class:`~colloc.transcription.Midpoint`).
    backward_euler_first : bool
        Solve backward Euler first and warm-start ``scheme`` from it (default). False:
        ``scheme`` starts from its own zero-defect start. Measured on 20 s of a motor-noise
        trial: :class:`~colloc.transcription.RadauIIA` so converged in 18 iterations and
        reached the midpoint rule's torques (0.59-0.69 N m rms from the truth against
        0.61-0.69), but took three times as long (126 s against 43 s, both beside another
        job on 2 cores); warm-started from backward Euler it needed 67 iterations.
    window_seconds, overlap_seconds : float
        The backward-Euler stage runs on windows of this length overlapping by this much
        (bounded work per solve, and no solve longer than the one measured to converge),
        stitched in the middle of each overlap for the midpoint stage.
    ipopt_options : mapping
        IPOPT options of every stage's solve (default :data:`IPOPT_OPTIONS`).
    """

    cutoff_hz: float = 6.0
    filter_order: int = 2
    start_friction_velocity: float = START_FRICTION_VELOCITY
    continuation: tuple[float, ...] = CONTINUATION
    residual_std: tuple[float, float, float] = RESIDUAL_STD
    max_halvings: int = 3
    max_iter: int = 300
    step_max_iter: int = 60
    scheme: Scheme = field(default_factory=Midpoint)
    backward_euler_first: bool = True
    window_seconds: float = 10.0
    overlap_seconds: float = 1.0
    ipopt_options: Mapping[str, Any] = field(default_factory=lambda: dict(IPOPT_OPTIONS))

    def problems(self) -> list[str]:
        """Every problem with the settings; empty when they are valid."""
        out = []

        def positive(name: str, value: Any) -> bool:
            ok = (
                isinstance(value, int | float)
                and not isinstance(value, bool)
                and np.isfinite(value)
                and value > 0
            )
            if not ok:
                out.append(f"{name}: expected a positive number, found {value!r}")
            return ok

        positive("cutoff_hz", self.cutoff_hz)
        positive("start_friction_velocity", self.start_friction_velocity)
        if positive("window_seconds", self.window_seconds) and positive(
            "overlap_seconds", self.overlap_seconds
        ):
            if self.overlap_seconds >= 0.5 * self.window_seconds:
                out.append(
                    f"overlap_seconds: expected less than half of window_seconds "
                    f"({self.window_seconds}), found {self.overlap_seconds}"
                )
        for i, s in enumerate(self.residual_std):
            positive(f"residual_std[{i}]", s)
        if len(self.residual_std) != 3:
            out.append(f"residual_std: expected 3 values, found {len(self.residual_std)}")
        for name, value, low in (
            ("filter_order", self.filter_order, 1),
            ("max_halvings", self.max_halvings, 0),
            ("max_iter", self.max_iter, 1),
            ("step_max_iter", self.step_max_iter, 1),
        ):
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                out.append(f"{name}: expected an integer >= {low}, found {value!r}")
        steps = [float(v) for v in self.continuation if positive("continuation", v)]
        if any(b >= a for a, b in zip(steps, steps[1:], strict=False)):
            out.append(f"continuation: expected decreasing slip scales, found {steps}")
        if not isinstance(self.backward_euler_first, bool):
            out.append(
                f"backward_euler_first: expected True or False, found {self.backward_euler_first!r}"
            )
        return out
