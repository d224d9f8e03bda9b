"""Turn a :class:`PendulumRun` into a stored record, a JSON summary, figures and an animation."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from colloc.identify.pendulum.workflow import PendulumRun
from colloc.identify.summaries import finite_or_none as _num
from colloc.identify.summaries import plain as _plain
from colloc.store import digest_arrays, package_versions, run_id_for

if TYPE_CHECKING:
    from colloc.store.record import RunRecord


def pendulum_run_id(run: PendulumRun) -> str:
    """A hash of the settings, the data and the package versions."""
    data = digest_arrays({"measurements": run.measurements, "force": run.force})
    return run_id_for(run.settings.to_dict(), data, package_versions())


def pendulum_summary(run: PendulumRun, run_id: str) -> dict[str, Any]:
    """The machine-readable summary written by ``colloc pendulum --json``."""
    stats = run.solution.stats
    return {
        "run_id": run_id,
        "settings": run.settings.to_dict(),
        "gains": {
            name: {
                "known": float(k),
                "identified": float(i),
                "std_error": _num(s),
                "initial": float(g),
            }
            for name, k, i, s, g in zip(
                run.gain_names,
                run.known_gains,
                run.identified_gains,
                run.standard_errors,
                run.initial_gains,
                strict=True,
            )
        },
        "uncertainty": {
            "method": run.uncertainty.method if run.uncertainty is not None else None,
            "blocks": run.uncertainty.blocks if run.uncertainty is not None else None,
            # the scheme's own error per gain (Richardson from a grid twice as fine)
            "discretisation_errors": dict(
                zip(run.gain_names, map(_num, run.discretisation_errors), strict=True)
            ),
            "discretisation": run.uncertainty.discretisation_note
            if run.uncertainty is not None
            else None,
        },
        "residual_diagnostics": run.diagnostics.as_dict() if run.diagnostics else None,
        "max_rel_gain_error": run.max_rel_gain_error,
        "max_gain_error_in_std_errors": _num(run.max_gain_error_in_se),
        "ipopt": {
            "status": stats["status"],
            "success": stats["success"],
            "iterations": stats["iterations"],
            "objective": stats["objective"],
            "constraint_violation": stats["constraint_violation"],
            "hint": stats["hint"],
        },
        "objective": stats["objective"],
        "objective_at_true_gains": run.objective_at_true_gains,
        "num_variables": stats["num_variables"],
        "times": {k: float(v) for k, v in run.timings.items()},
        "notes": run.notes,
    }


def pendulum_record(run: PendulumRun, run_id: str) -> RunRecord:
    """The database record of a run (settings, versions, statistics, log, gains, arrays)."""
    from colloc.store.record import ParameterRow, RunRecord  # pandas: only when storing

    stats = {k: v for k, v in run.solution.stats.items() if k not in ("ipopt_log",)}
    stats["times"] = dict(run.timings)
    stats["max_rel_gain_error"] = run.max_rel_gain_error
    stats["objective_at_true_gains"] = run.objective_at_true_gains
    settings = {**run.settings.to_dict(), "num_nodes": run.settings.num_nodes}
    params = [
        ParameterRow(name, float(k), float(i), _num(s))
        for name, k, i, s in zip(
            run.gain_names,
            run.known_gains,
            run.identified_gains,
            run.standard_errors,
            strict=True,
        )
    ]
    arrays = {
        "times": run.times,
        "force": run.force,
        "measurements": run.measurements,
        "true_states": run.true_states,
        "identified_states": run.identified_states,
        "defects": run.defects,
        "initial_gains": run.initial_gains,
    }
    return RunRecord(
        run_id=run_id,
        kind="pendulum",
        settings=_plain(settings),
        versions=package_versions(),
        statistics=_plain(stats),
        ipopt_log=run.solution.stats["ipopt_log"],
        parameters=params,
        arrays=arrays,
    )


def save_pendulum_plots(
    run: PendulumRun, directory: Path, formats: tuple[str, ...] = ("png", "svg")
) -> list[Path]:
    """Cart force, states, measured vs identified, constraint violations, gains."""
    from colloc.plot import (  # matplotlib: only when figures are asked for
        plot_constraint_violations,
        plot_force,
        plot_gains,
        plot_states,
        plot_trajectory_comparison,
        save_figure,
    )

    n = run.settings.num_links
    names = [f"q{i}" for i in range(n + 1)] + [f"u{i}" for i in range(n + 1)]
    interval_rows = run.problem.layout.blocks[0]
    defects = run.defects[: interval_rows.size].reshape(interval_rows.count, interval_rows.rows)
    figures = {
        "force": plot_force(run.times, run.force),
        "states": plot_states(run.times, run.true_states, names),
        "trajectory_comparison": plot_trajectory_comparison(
            run.times, run.measurements, run.identified_states[:, : n + 1], names[: n + 1]
        ),
        "constraint_violations": plot_constraint_violations(
            run.times[1:], defects, [f"defect {i}" for i in range(defects.shape[1])]
        ),
        "gains": plot_gains(
            run.known_gains, run.identified_gains, run.standard_errors, run.gain_names
        ),
    }
    paths: list[Path] = []
    for stem, fig in figures.items():
        paths += save_figure(fig, directory, stem, formats)
    return paths


def save_pendulum_animation(run: PendulumRun, path: Path) -> Path:
    """The identified motion as a GIF (or MP4 when the path ends in .mp4)."""
    from colloc.plot import animate_pendulum_cart  # matplotlib: only when animating

    n = run.settings.num_links
    return animate_pendulum_cart(run.times, run.identified_states[:, : n + 1], run.lengths, path)
