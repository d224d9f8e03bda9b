"""Are the error bars honest? Bias, spread and coverage of the pendulum gains over noise realisations.

For the 1- and 2-link cart pendulum and three kinds of data:
  (a) sensor noise only;
  (b) plus motor noise on every joint torque, of standard deviation a tenth of the
      controller's rms torque (measured on the noise-free closed loop);
  (c) plus noise on the measured cart force, a tenth of the force's rms;
each realisation (seed) is identified twice: by today's method (exact dynamics, the measured
force taken as exact, KKT standard errors) and by the new one (the noise model's maximum a
posteriori fit with sandwich standard errors). A third row, "robust", is today's fit with the
sandwich standard errors (no second solve). Per gain: bias (with its Monte Carlo standard
error, spread / sqrt(realisations), to read it against), spread, mean reported standard error
and the fraction of estimates within 2 and 3 standard errors.

Every fit is one run of a ``colloc.batch`` batch (Dask, one worker per core), stored in an
SQLite file beside the JSON, so an interrupted or extended calibration (more realisations)
re-uses the fits already made. The robust row is its own run: the exact fit again, with
sandwich standard errors (the pendulum study's default); the row "autoregressive" is the
exact fit with the library's default errors without a noise model
(``method="autoregressive"``).

The case ``bound`` (its own JSON, ``..._bound.json``) is a mass-spring-damper whose damping's
truth sits on its bound ``c >= 0``, posed with the library's defaults: how many realisations end
on the bound, whether each of those is marked unreliable with no standard error for ``c``, and
the coverage of the free parameter.

The cases ``trials-slow`` and ``trials-motor`` (``..._trials-slow.json``, ...) are several
trials sharing parameters (``colloc.Trials``): the four trials of
``docs/examples/shared_trials.py`` (their own lengths, rates, forces, starts and sensor
offsets; damping and stiffness shared) with a disturbance force added (an unmodelled smooth
one, or motor noise), so that the residuals are correlated within a trial. Per parameter:
coverage of the library's default errors (the autoregressive ones), of the KKT errors, of
the sandwich over its default blocks inside trials and with two blocks per trial, and
(motor noise) of the MAP fit that models the noise.

Usage: python benchmarks/uncertainty_calibration.py [--links 1 2]
       [--cases a b c bound trials-slow trials-motor]
       [--realisations 50] [--duration 30] [--workers 2]
       [--out benchmarks/results/uncertainty_calibration.json]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

METHODS = {
    "today": {"noise_model": False, "uncertainty": "kkt"},
    "new": {"noise_model": True, "uncertainty": "sandwich"},
    "robust": {"noise_model": False, "uncertainty": "sandwich"},
    "autoregressive": {"noise_model": False, "uncertainty": "autoregressive"},
}
#: Rows of the summary: the two methods, and today's fit with sandwich standard errors.
ROWS = tuple(METHODS)


def noise_levels(num_links: int, duration: float) -> dict[str, float]:
    """A tenth of the controller's rms torque and of the cart force's rms (noise free)."""
    from colloc.identify.pendulum.workflow import PendulumSettings, run_pendulum

    run = run_pendulum(PendulumSettings(num_links=num_links, duration=duration))
    K = run.known_gains.reshape(num_links, -1)
    torques = run.true_states @ K.T
    return {
        "process_noise": float(np.sqrt(np.mean(torques**2))) / 10.0,
        "input_noise": float(np.sqrt(np.mean(run.force**2))) / 10.0,
    }


def calibrate(
    links: int, duration: float, realisations: int, levels: dict[str, float], url: str, workers: int
) -> list[dict[str, Any]]:
    """Every method on every realisation, as one batch; the runs read back from the store."""
    from colloc.batch import Task, run_batch, task_key
    from colloc.identify.pendulum.workflow import PendulumSettings
    from colloc.store import RunStore

    tasks, where = [], []
    for seed in range(realisations):
        for name, method in METHODS.items():
            settings = PendulumSettings(
                num_links=links,
                duration=duration,
                sensor_noise=True,
                initial_guess="direct",
                seed=seed,
                **levels,
                **method,
            )
            key = task_key("pendulum", settings.to_dict(), {})
            tasks.append(Task(len(tasks), "pendulum", settings, key=key))
            where.append((seed, name))
    outcome = run_batch(tasks, url, workers=workers, spec={"benchmark": "uncertainty_calibration"})
    runs: dict[int, dict[str, Any]] = {}
    with RunStore(url) as store:
        for position, (seed, name) in enumerate(where):
            result = outcome.results[position]
            run = runs.setdefault(seed, {"seed": seed})
            if result.run_id is None:
                run[name] = {"success": False, "gains": [], "std_errors": [], "seconds": 0.0}
                continue
            record = store.get(result.run_id, arrays=False)
            rows = record.parameters
            run["known"] = [r.known for r in rows]
            run[name] = {
                "success": bool(record.statistics["success"]) and result.status != "failed",
                "gains": [r.identified for r in rows],
                "std_errors": [np.nan if r.std_error is None else r.std_error for r in rows],
                "seconds": result.seconds,
                "notes": len(record.statistics.get("notes", []) or []),
            }
    return [runs[seed] for seed in sorted(runs)]


def summarise(runs: list[dict[str, Any]], method: str) -> dict[str, Any]:
    """Bias, spread, mean SE and coverage per gain over the successful realisations."""
    ok = [r for r in runs if r[method]["success"]]
    known = np.array(runs[0]["known"])
    est = np.array([r[method]["gains"] for r in ok])
    se = np.array([r[method]["std_errors"] for r in ok])
    err = est - known
    z = np.abs(err) / se
    bias = err.mean(axis=0)
    return {
        "realisations": len(ok),
        "failed": len(runs) - len(ok),
        "bias": bias.tolist(),
        "relative_bias": (bias / np.abs(known)).tolist(),
        "mean_abs_relative_bias": float(np.mean(np.abs(bias / known))),
        "bias_monte_carlo_se": (err.std(axis=0, ddof=1) / np.sqrt(len(ok))).tolist(),
        "mean_abs_bias_in_monte_carlo_se": float(
            np.mean(np.abs(bias) / (err.std(axis=0, ddof=1) / np.sqrt(len(ok))))
        ),
        "spread": err.std(axis=0, ddof=1).tolist(),
        "mean_std_error": se.mean(axis=0).tolist(),
        "within_2_se": float(np.mean(z <= 2)),
        "within_3_se": float(np.mean(z <= 3)),
        "within_3_se_per_gain": np.mean(z <= 3, axis=0).tolist(),
        "mean_seconds": float(np.mean([r[method]["seconds"] for r in ok])),
    }


def bound_case(realisations: int, seed0: int = 0) -> dict[str, Any]:
    """A parameter whose truth sits on its bound: ``x'' + c x' + k x = F`` with ``c >= 0``
    and ``c = 0`` (no damping), ``k = 25``, 10 s at 100 Hz, position noise 2 mm, through the
    library's defaults (``parameter_uncertainty`` as a user calls it). About half the
    realisations end with ``c`` on its bound: those must give ``c`` no standard error and
    mark the solve unreliable, and ``k``'s error bar must stay honest in every realisation.
    """
    import sympy as sm
    from sympy.physics.mechanics import dynamicsymbols

    import colloc

    t = dynamicsymbols._t
    x, v, F = dynamicsymbols("x v F")
    c, k = sm.symbols("c k")
    model = colloc.Model.from_equations(
        [x.diff(t) - v, v.diff(t) + c * v + k * x - F], [x, v], known_inputs=[F], outputs=[x]
    )
    times = np.arange(1001) / 100.0
    force = np.sin(2.1 * times) + 0.6 * np.sin(7.3 * times) + 0.3 * np.sin(13.0 * times)
    sigma = 0.002
    from scipy.integrate import solve_ivp

    def push(time: float) -> float:
        return float(np.sin(2.1 * time) + 0.6 * np.sin(7.3 * time) + 0.3 * np.sin(13.0 * time))

    clean = solve_ivp(
        lambda time, y: [y[1], push(time) - 25.0 * y[0]],
        (0.0, times[-1]),
        [0.0, 0.0],
        t_eval=times,
        rtol=1e-10,
        atol=1e-12,
    ).y[0]
    rows = []
    for seed in range(seed0, seed0 + realisations):
        rng = np.random.default_rng(seed)
        measured = clean + sigma * rng.standard_normal(times.size)
        problem = colloc.Problem(
            model,
            times,
            known_trajectories={F: force},
            objective=colloc.Tracking({x: measured}, 1 / sigma**2),
            bounds={c: (0.0, 10.0)},
            cache=True,
        )
        guess = problem.initial_guess(
            {x: measured, v: np.gradient(measured, times)}, {c: 0.5, k: 20.0}
        )
        solution = problem.solve(guess)
        errors = colloc.parameter_uncertainty(problem, solution).standard_errors
        rows.append(
            {
                "seed": seed,
                "success": solution.success,
                "reliable": solution.status.reliable,
                "at_bound": [str(p) for p in solution.status.at_bounds],
                "c": solution.parameters[c],
                "k": solution.parameters[k],
                "se_c": errors[c],
                "se_k": errors[k],
            }
        )
    held = [r for r in rows if "c" in r["at_bound"]]
    free = [r for r in rows if "c" not in r["at_bound"]]
    z_k = np.array([abs(r["k"] - 25.0) / r["se_k"] for r in rows])
    z_c = np.array([abs(r["c"]) / r["se_c"] for r in free])
    return {
        "case": "bound",
        "realisations": len(rows),
        "c_at_bound": len(held),
        "at_bound_with_finite_se": sum(bool(np.isfinite(r["se_c"])) for r in held),
        "at_bound_marked_unreliable": sum(not r["reliable"] for r in held),
        "k_within_3_se": float(np.mean(z_k <= 3)),
        "k_within_3_se_when_c_held": float(np.mean(z_k[[r in held for r in rows]] <= 3))
        if held
        else None,
        "c_within_3_se_when_free": float(np.mean(z_c <= 3)) if free else None,
        "runs": rows,
    }


#: Disturbances of the several-trials case: an unmodelled smooth force (20 sines between 0.3
#: and 8 Hz at random phases, rms 0.4 N against driving forces of 2-5 N), or motor noise (white
#: at the samples, linear between them, sd 0.5 N) that a MAP fit can model.
TRIAL_DISTURBANCES = ("slow", "motor")


def trials_case(realisations: int, disturbance: str, seed0: int = 0) -> dict[str, Any]:
    """Several trials sharing parameters (module docstring): ``colloc.Trials`` of the docs
    example's four trials (Hermite-Simpson, position noise 2 mm) with a disturbance
    (:data:`TRIAL_DISTURBANCES`), fitted with exact dynamics and errors by
    ``parameter_uncertainty`` as a user calls it (the default), by ``method="kkt"``, and by
    the sandwich over its default blocks and with two blocks per trial; with motor noise also
    by the MAP fit that models it (``process_noise``), default errors."""
    import sys

    import sympy as sm
    from scipy.integrate import solve_ivp
    from sympy.physics.mechanics import dynamicsymbols

    import colloc

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "docs" / "examples"))
    try:
        import shared_trials as example
    finally:
        sys.path.pop(0)
    c, k, m, F, x, v, y = (
        example.c,
        example.k,
        example.m,
        example.F,
        example.x,
        example.v,
        example.y,
    )
    w = dynamicsymbols("w")
    motor_sd = 0.5
    truth = {str(p): value for p, value in example.SHARED.items()}
    offsets = [sm.Symbol(f"b{i}") for i in range(len(example.TRIALS))]
    truth.update({str(b): design[-1] for b, design in zip(offsets, example.TRIALS, strict=True)})
    gain = 0.4 * np.sqrt(2.0 / 20)  # 20 sines of this amplitude: rms 0.4 N
    rows = []
    for seed in range(seed0, seed0 + realisations):
        rng = np.random.default_rng(seed)
        exact_fits, map_fits, guesses = [], [], []
        for b, (duration, rate, amplitude, frequency, start, offset) in zip(
            offsets, example.TRIALS, strict=True
        ):
            times = np.arange(0.0, duration + 0.5 / rate, 1.0 / rate)
            omega = 2 * np.pi * rng.uniform(0.3, 8.0, 20)
            phase = rng.uniform(0, 2 * np.pi, 20)
            noise = rng.normal(0.0, motor_sd, times.size)

            def force(s, amplitude=amplitude, frequency=frequency):
                return amplitude * np.sin(frequency * s) + 0.5 * amplitude * np.sin(
                    3.7 * frequency * s
                )

            def push(s, omega=omega, phase=phase, times=times, noise=noise):
                if disturbance == "slow":
                    return gain * np.sum(np.sin(omega * s + phase))
                return np.interp(s, times, noise)

            def rhs(s, state, force=force, push=push):
                total = force(s) + push(s)
                return [
                    state[1],
                    total - example.SHARED[c] * state[1] - example.SHARED[k] * state[0],
                ]

            exact = solve_ivp(
                rhs,
                times[[0, -1]],
                start,
                t_eval=times,
                rtol=1e-10,
                atol=1e-12,
                max_step=0.5 / rate,
            ).y[0]
            sensor = exact + offset + rng.normal(0.0, example.SIGMA, times.size)
            pose = {
                "scheme": colloc.transcription.HermiteSimpson(),
                "known_trajectories": {F: force(times)},
                "known_parameters": {m: 1.0},
                "objective": colloc.Tracking({y: sensor}, 1.0 / example.SIGMA**2),
            }
            exact_fits.append(colloc.Problem(example.plant(b), times, **pose))
            if disturbance == "motor":
                noisy = example.plant(b).with_disturbances({F: w})
                map_fits.append(colloc.Problem(noisy, times, process_noise={w: motor_sd}, **pose))
            guesses.append(({x: sensor, v: np.gradient(sensor, times)}, {b: 0.0}))
        row: dict[str, Any] = {"seed": seed}
        for fit, problems in (("exact", exact_fits), ("map", map_fits)):
            if not problems:
                continue
            design = colloc.Trials(problems)
            z0 = design.initial_guess(
                [p.initial_guess(*g) for p, g in zip(problems, guesses, strict=True)],
                {c: 1.0, k: 10.0},
            )
            solution = design.solve(z0)
            names = [str(p) for p in design.unknown_parameters]
            row[fit] = {
                "success": solution.success,
                "estimate": dict(
                    zip(names, map(solution.parameters.get, design.unknown_parameters), strict=True)
                ),
            }
            ways = {"default": {}}
            if fit == "exact":
                ways["kkt"] = {"method": "kkt"}
                ways["blocks"] = {"method": "sandwich"}
                ways["halves"] = {"method": "sandwich", "blocks": 2}
            for way, options in ways.items():
                errors = colloc.parameter_uncertainty(
                    design, solution, discretisation=False, **options
                )
                row[fit][f"se_{way}"] = {
                    str(p): errors.standard_errors[p] for p in design.unknown_parameters
                }
                row[fit][f"method_{way}"] = f"{errors.method} ({errors.blocks} blocks)"
        rows.append(row)

    def summary(fit: str, way: str) -> dict[str, Any]:
        good = [r[fit] for r in rows if r[fit]["success"]]
        key = f"se_{way}"
        return {
            "method": good[0][f"method_{way}"] if good else None,
            "failed": len(rows) - len(good),
            "within_3_se": {
                n: float(np.mean([abs(r["estimate"][n] - t) <= 3 * r[key][n] for r in good]))
                for n, t in truth.items()
            },
            "spread_over_mean_se": {
                n: float(
                    np.std([r["estimate"][n] for r in good], ddof=1)
                    / np.mean([r[key][n] for r in good])
                )
                for n in truth
            },
            "bias_in_spread": {
                n: float(
                    (np.mean([r["estimate"][n] for r in good]) - t)
                    / np.std([r["estimate"][n] for r in good], ddof=1)
                )
                for n, t in truth.items()
            },
        }

    record: dict[str, Any] = {
        "case": "trials",
        "disturbance": disturbance,
        "realisations": len(rows),
        "truth": truth,
        "exact_default": summary("exact", "default"),
        "exact_kkt": summary("exact", "kkt"),
        "exact_blocks": summary("exact", "blocks"),
        "exact_halves": summary("exact", "halves"),
    }
    if disturbance == "motor":
        record["map_default"] = summary("map", "default")
    record["runs"] = rows
    return record


def figure(results: list[dict[str, Any]], path: Path) -> None:
    """Coverage within 3 SE and mean |relative bias| per case, for each row."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [f"{r['links']}-link ({r['case']})" for r in results]
    x = np.arange(len(results))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    width = 0.8 / len(ROWS)
    for i, method in enumerate(ROWS):
        shift = width * (i - (len(ROWS) - 1) / 2)
        a1.bar(x + shift, [r[method]["within_3_se"] for r in results], width, label=method)
        a2.bar(
            x + shift,
            [100 * r[method]["mean_abs_relative_bias"] for r in results],
            width,
            label=method,
        )
    a1.axhline(0.9, color="k", lw=0.8, ls="--")
    a1.set_ylabel("fraction of estimates within 3 reported SE")
    a2.set_ylabel("mean |bias| of the gains, % of the gain")
    for a in (a1, a2):
        a.set_xticks(x, labels, rotation=30, ha="right")
        a.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--links", type=int, nargs="+", default=[1, 2])
    parser.add_argument(
        "--cases",
        nargs="+",
        default=["a", "b", "c"],
        choices=["a", "b", "c", "bound", "trials-slow", "trials-motor"],
    )
    parser.add_argument("--realisations", type=int, default=50)
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument(
        "--out", type=Path, default=Path("benchmarks/results/uncertainty_calibration.json")
    )
    args = parser.parse_args()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    results = []
    runs = {"bound": bound_case} | {
        f"trials-{kind}": functools.partial(trials_case, disturbance=kind)
        for kind in TRIAL_DISTURBANCES
    }
    for name, run in runs.items():
        if name in args.cases:
            t0 = time.perf_counter()
            record = run(args.realisations)
            record["wall_seconds"] = time.perf_counter() - t0
            print(json.dumps({k: v for k, v in record.items() if k != "runs"}), flush=True)
            path = args.out.with_name(f"{args.out.stem}_{name}.json")
            path.write_text(json.dumps(record, indent=1) + "\n")
            args.cases = [case for case in args.cases if case != name]
    if not args.cases:
        return
    for links in args.links:
        levels = noise_levels(links, args.duration)
        print(f"{links}-link noise levels: {levels}", flush=True)
        for case in args.cases:
            pn = levels["process_noise"] if case in "bc" else 0.0
            fn = levels["input_noise"] if case == "c" else 0.0
            t0 = time.perf_counter()
            runs = calibrate(
                links,
                args.duration,
                args.realisations,
                {"process_noise": pn, "input_noise": fn},
                f"sqlite:///{args.out.with_suffix('.db').resolve()}",
                args.workers,
            )
            same = max(
                float(
                    np.max(
                        np.abs(np.subtract(r["new"]["gains"], r["today"]["gains"]))
                        / np.abs(r["known"])
                    )
                )
                for r in runs
            )
            record = {
                "links": links,
                "case": case,
                "process_noise": pn,
                "input_noise": fn,
                "duration": args.duration,
                "wall_seconds": time.perf_counter() - t0,
                **{row: summarise(runs, row) for row in ROWS},
                "max_rel_difference_new_vs_today": same,
                "runs": runs,
            }
            results.append(record)
            brief = {k: v for k, v in record.items() if k != "runs"}
            for m in ROWS:
                brief[m] = {
                    k: brief[m][k]
                    for k in (
                        "mean_abs_relative_bias",
                        "mean_abs_bias_in_monte_carlo_se",
                        "within_2_se",
                        "within_3_se",
                        "failed",
                    )
                }
            print(json.dumps(brief), flush=True)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps(results, indent=1) + "\n")
    figure(results, args.out.with_suffix(".png"))
    print(f"-> {args.out} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
