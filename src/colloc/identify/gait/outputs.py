"""Turn a :class:`GaitIdentification` into a run id, a JSON summary, a stored record and
figures."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from colloc.identify.gait.estimate import mean_cycle_torque
from colloc.identify.gait.workflow import JOINT_NAMES, GaitIdentification
from colloc.identify.summaries import finite_or_none, plain
from colloc.store import package_versions, run_id_for

if TYPE_CHECKING:
    from colloc.store.record import RunRecord

#: ``kind`` of a gait identification in the results store.
KIND = "gait-identify"


def gait_run_id(run: GaitIdentification) -> str:
    """A hash of the settings (the trial's path left out), the trial's data and versions."""
    settings = {k: v for k, v in run.settings.to_dict().items() if k != "trial"}
    return run_id_for(settings, run.data_digest, package_versions())


#: What the summary's numbers mean, written into it (``definitions``).
DEFINITIONS: dict[str, str] = {
    "K_relative_error": (
        "|K_est - K_true| / |K_true|, Frobenius norms over all P x 6 x n_s entries (the "
        "structure's zeros included); only when the true controller is known"
    ),
    "Tstar_relative_error": "|T*_est - T*_true| / |T*_true| over all P x 6 entries",
    "K_relative_bound": (
        "sqrt(sum of the Cramer-Rao bound's variances of K) / |K|, relative to the truth when "
        "known, else to the estimate: the relative error no unbiased estimator of this design "
        "(the fed-back states known) goes below"
    ),
    "Tstar_relative_bound": "the same for T*",
    "K_relative_bound_states_known": "K_relative_bound, by its name",
    "Tstar_relative_bound_states_known": "Tstar_relative_bound, by its name",
    "K_relative_bound_full_design": (
        "the same from the whole design's bound, the states unknown: the closed loop's maximum "
        "a posteriori problem (tracked signals at their noise, the motor noise a penalised "
        "residual) with the states eliminated, summed over pieces of the smoothed windows "
        "(--design-bound full; colloc.identify.gait.design_bound)"
    ),
    "Tstar_relative_bound_full_design": "the same for T*",
    "fraction_within_3se": (
        "share of the T* and allowed K entries whose error against the truth is within 3 of "
        "their standard errors (about 0.99 for honest Gaussian errors)"
    ),
    "T0": (
        "T0(phi_p) = T*(phi_p) - K(phi_p) s_mean(phi_p) [N m] per schedule point and joint: the "
        "torque each controller applies on the fit window's mean gait cycle s_mean (the "
        "joint-moment profile; T* alone is the intercept on absolute signals)"
    ),
    "torque_vaf": (
        "1 - var(predicted - measured) / var(measured) of each joint's held-out torque, the "
        "prediction from the held-out smoothed signals"
    ),
    "walks": (
        "the held-out forward simulation under the identified controller did not fall (it "
        "says nothing of how close it walked: see angle_rms_phase and against_truth_walk)"
    ),
    "angle_rms": (
        "joint angles' RMS [deg] between the held-out walk and the record, sample by sample: "
        "a walk without the record's motor noise drifts in phase after a perturbation and "
        "reads tens of degrees here under any controller, the true one's included"
    ),
    "angle_rms_phase": (
        "joint angles' RMS [deg] over the gait cycle between the walk's and the record's mean "
        "strides, each stride normalised from one right heel strike to the next: the shape of "
        "the walk without its drift in phase"
    ),
    "truth_walk": (
        "the true controller's walk of the held-out part under the same belt from the same "
        "start (only when the truth is known)"
    ),
    "against_truth_walk": (
        "the identified controller's walk against the true controller's over the time both "
        "walked: angle_rms_deg sample by sample, angle_rms_phase_deg between mean strides [deg]"
    ),
}


def mean_cycle_torques(run: GaitIdentification) -> dict[str, np.ndarray]:
    """``T0`` of each controller of the run (identified, direct, truth when known), (P, 6)."""
    if run.mean_signals is None:
        return {}
    controllers = {"collocation": run.collocation, "direct": run.direct}
    if run.truth is not None:
        controllers["truth"] = run.truth
    return {name: mean_cycle_torque(c, run.mean_signals) for name, c in controllers.items()}


def gait_summary(run: GaitIdentification, run_id: str) -> dict[str, Any]:
    """The machine-readable summary written by ``colloc gait identify --json``."""
    v = run.validation
    return plain(
        {
            "run_id": run_id,
            "settings": run.settings.to_dict(),
            "points": run.points,
            "feedback": run.feedback,
            "window": list(run.window),
            "split_time": run.split_time,
            **run.metrics,
            "validation": {
                "torque_vaf": v["torque_vaf"],
                "torque_vaf_measured_states": v.get("torque_vaf_measured_states"),
                "walks": v.get("walks"),
                "simulation": v.get("message"),
                "simulated_seconds": v.get("simulated_seconds"),
                "strides": v.get("strides"),
                "measured_strides": v.get("measured_strides"),
                "angle_rms": v.get("angle_rms_deg"),
                "angle_vaf": v.get("angle_vaf"),
                "angle_rms_phase": v.get("angle_rms_phase_deg"),
                "direct_walk": v.get("direct_walk"),
                "truth_walk": v.get("truth_walk"),
                "against_truth_walk": v.get("against_truth_walk"),
            },
            # fitted against measured joint angles over the fit window, degrees
            "fit_angle_rms": dict(
                zip(
                    JOINT_NAMES,
                    np.degrees(np.sqrt(np.mean((run.fitted - run.measured) ** 2, axis=0))),
                    strict=True,
                )
            ),
            "status": run.solver["status"],
            "success": run.solver["success"],
            "iterations": run.solver["iterations"],
            "windows": run.solver.get("windows"),
            "objective": run.solver["objective"],
            "constraint_violation": run.solver["constraint_violation"],
            "problem": run.problem_size,
            "times": run.timings,
            "peak_rss_mb": run.peak_rss_mb,
            "model": run.model,
            "T0": mean_cycle_torques(run),
            "definitions": DEFINITIONS,
            "notes": run.notes,
        }
    )


def gait_record(run: GaitIdentification, run_id: str) -> RunRecord:
    """The database record: settings, statistics, solver log, every T* and K entry, arrays."""
    from colloc.store.record import ParameterRow, RunRecord  # pandas: only when storing

    rows = []
    est, truth = run.collocation, run.truth
    se_T = est.Tstar_se if est.Tstar_se is not None else np.full_like(est.Tstar, np.nan)
    se_K = est.K_se if est.K_se is not None else np.full_like(est.K, np.nan)
    for p in range(run.points):
        for j, joint in enumerate(JOINT_NAMES):
            known = None if truth is None else float(truth.Tstar[p, j])
            rows.append(
                ParameterRow(
                    f"Tstar[{p}][{joint}]",
                    known,
                    float(est.Tstar[p, j]),
                    finite_or_none(se_T[p, j]),
                )
            )
            for i, signal in enumerate(run.feedback):
                if run.mask[j, i]:
                    known = None if truth is None else float(truth.K[p, j, i])
                    rows.append(
                        ParameterRow(
                            f"K[{p}][{joint}][{signal}]",
                            known,
                            float(est.K[p, j, i]),
                            finite_or_none(se_K[p, j, i]),
                        )
                    )
    summary = gait_summary(run, run_id)
    statistics = {k: v for k, v in summary.items() if k not in ("settings", "run_id")}
    arrays = {
        "times": run.times,
        "measured_angles": run.measured,
        "fitted_angles": run.fitted,
        "Tstar": est.Tstar,
        "K": est.K,
        "direct_Tstar": run.direct.Tstar,
        "direct_K": run.direct.K,
    }
    if est.K_se is not None and est.Tstar_se is not None:
        arrays.update(Tstar_se=est.Tstar_se, K_se=est.K_se)
    arrays.update({f"T0_{name}": t0 for name, t0 in mean_cycle_torques(run).items()})
    if "simulated_angles" in run.validation:
        arrays.update(
            validation_times=run.validation["times"],
            validation_measured_angles=run.validation["measured_angles"],
            validation_simulated_angles=run.validation["simulated_angles"],
        )
    return RunRecord(
        run_id=run_id,
        kind=KIND,
        settings=run.settings.to_dict(),
        versions=package_versions(),
        statistics=statistics,
        ipopt_log=run.solver["log"],
        parameters=rows,
        arrays=arrays,
    )


#: Title and curve label of the fitted-angles figure per method: what the fitted motion is.
FITTED_ANGLES: dict[str, tuple[str, str]] = {
    "smoother": (
        "fit window: the smoother's motion (torques free, not the controller's)",
        "smoother's fit",
    ),
    "closed-loop": (
        "fit window: the model closed by the identified controller",
        "closed-loop fit",
    ),
}


def save_gait_plots(
    run: GaitIdentification, directory: Path, formats: tuple[str, ...] = ("png", "svg")
) -> list[Path]:
    """T*(phi) and each joint's own angle and rate gains K(phi) with ±2 SE bands against the
    direct fit and the truth, K's norm per joint row; measured vs fitted angles; held-out
    torque VAF; the held-out forward simulation."""
    from colloc.plot import (  # matplotlib: only when figures are asked for
        plot_angle_comparison,
        plot_schedule,
        plot_torque_vaf,
        save_figure,
    )

    est = run.collocation
    tstar = {"collocation": (est.Tstar, est.Tstar_se), "direct": (run.direct.Tstar, None)}
    gains = {"collocation": (_row_norm(est.K), None), "direct": (_row_norm(run.direct.K), None)}
    if run.truth is not None:
        tstar["truth"] = (run.truth.Tstar, None)
        gains["truth"] = (_row_norm(run.truth.K), None)
    figures = {
        "tstar_schedule": plot_schedule(tstar, JOINT_NAMES, "T*(phi) [N m], ±2 SE"),
        "gain_schedule": plot_schedule(gains, JOINT_NAMES, "||K_j(phi)|| per torque row"),
    }
    for signal, stem, unit in (
        ("angle", "stiffness_schedule", "N m/rad"),
        ("rate", "damping_schedule", "N m s/rad"),
    ):
        own = _own_gains(run, signal)
        if own:
            figures[stem] = plot_schedule(
                own, JOINT_NAMES, f"each joint's own {signal} gain K(phi) [{unit}], ±2 SE"
            )
    figures |= {
        "mean_cycle_torque": plot_schedule(
            {name: (t0, None) for name, t0 in mean_cycle_torques(run).items()},
            JOINT_NAMES,
            "T0(phi) = T*(phi) - K(phi) s_mean(phi) [N m]: torque on the mean gait cycle",
        ),
        "fitted_angles": plot_angle_comparison(
            run.times, run.measured, run.fitted, JOINT_NAMES, *FITTED_ANGLES[run.settings.method]
        ),
        "torque_vaf": plot_torque_vaf(run.validation["torque_vaf"], "held-out torque VAF"),
    }
    v = run.validation
    if "simulated_angles" in v:
        figures["validation_walk"] = plot_angle_comparison(
            v["times"],
            v["measured_angles"],
            v["simulated_angles"],
            JOINT_NAMES,
            f"held-out part, forward simulation: {v['message']}",
            "simulated",
        )
    if "walk_signals" in v:
        figures["validation_walk_phase"] = _mean_strides_figure(v)
    paths: list[Path] = []
    for stem, fig in figures.items():
        paths += save_figure(fig, directory, stem, formats)
    return paths


#: How the held-out walks are named in the mean-stride figure.
WALK_LABELS = {
    "collocation": "identified controller's walk",
    "direct": "direct fit's walk",
    "truth": "true controller's walk",
}


def _mean_strides_figure(validation: dict[str, Any]) -> Any:
    """The held-out walks' mean strides over the gait cycle against the record's strides."""
    from colloc.data.phase import phase_normalised
    from colloc.plot import plot_mean_strides

    held_out = validation["held_out"]
    # the record's strides over the whole held-out part, each walk's over what it walked
    phase, record, _ = phase_normalised(held_out["times"], held_out["angles"], held_out["strikes"])
    walks, short = {}, []
    for name, w in validation["walk_signals"].items():
        label = WALK_LABELS.get(name, name)
        mean = phase_normalised(
            w["times"] - w["times"][0], w["simulated_angles"], w["simulated_strikes"]
        )[2]
        if np.isnan(mean).all():
            short.append(label)  # fell before a whole stride: no mean stride to draw
        else:
            walks[label] = mean
    title = "held-out part over the gait cycle: the record's strides and each walk's mean stride"
    if short:
        title += f"\n(no whole stride, not drawn: {', '.join(short)})"
    return plot_mean_strides(phase, record, walks, JOINT_NAMES, title)


def _own_gains(
    run: GaitIdentification, signal: str
) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    """Each joint's gain on its own ``angle`` or ``rate`` (P, 6) per controller, with the
    identified one's standard errors; empty when the feedback lacks one of them."""
    columns = [f"{joint}_{signal}" for joint in JOINT_NAMES]
    if not all(c in run.feedback for c in columns):
        return {}
    index = [run.feedback.index(c) for c in columns]
    rows = np.arange(len(JOINT_NAMES))

    def own(K: np.ndarray) -> np.ndarray:
        return K[:, rows, index]

    est = run.collocation
    out: dict[str, tuple[np.ndarray, np.ndarray | None]] = {
        "collocation": (own(est.K), None if est.K_se is None else own(est.K_se)),
        "direct": (own(run.direct.K), None),
    }
    if run.truth is not None:
        out["truth"] = (own(run.truth.K), None)
    return out


def _row_norm(K: np.ndarray) -> np.ndarray:
    return np.linalg.norm(K, axis=2)
