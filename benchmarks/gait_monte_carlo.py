"""Monte Carlo of a short walking design: do repeated identifications reach the Cramér-Rao
bound the identification reports, or does the bound flatter them? (issue 49)

Each replicate is one synthetic perturbed walk of the same design (speed, length, motor
noise, sensor noise, the same true controller) with its own seed, so its own perturbations,
motor noise and sensor noise; each is identified with ``colloc gait identify``'s defaults
(``--no-simulate``, and ``--design-bound full`` unless ``--design-bound states-known``).
Over the replicates the script sets side by side, for K and T*:

- the root mean square of the relative error ``|est - true| / |true|`` (Frobenius norms, as
  the identification's ``K_relative_error``), against the root mean square of each bound the
  runs reported (``K_relative_bound_states_known``, ``K_relative_bound_full_design``): a
  bound that repeated fits reach gives a ratio near 1, a bound that flatters them one well
  above, and no unbiased estimator goes below it;
- that error split into bias (``|mean est - true| / |true|``, with its Monte Carlo standard
  error) and spread about the mean;
- the reported standard errors against the spread each entry shows over the replicates
  (median ratio), and the share of entries within 3 reported standard errors.

Ratios carry a bootstrap interval over replicates (the replicate is the unit). Usage::

    python benchmarks/gait_monte_carlo.py --replicates 12 --duration 24 --speed 1.1 \\
        --motor-noise 3 --seed-base 500 --parallel 2 [--design-bound full] \\
        [--window-strides 4] [--out benchmarks/results/monte_carlo]

Every simulated trial and every replicate's estimate (``replicate-<seed>.npz``) stays in
``--out``, so an interrupted run, or a longer one (more replicates), re-uses what is done.
One JSON record per run is appended to ``benchmarks/results/gait_monte_carlo.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from results_file import append_record

RESULTS = Path(__file__).parent / "results" / "gait_monte_carlo.json"
#: Bootstrap resamples of the replicates for the ratios' intervals, and its seed.
BOOTSTRAP, BOOTSTRAP_SEED = 2000, 0


def colloc_command() -> list[str]:
    """The ``colloc`` command of this interpreter's environment."""
    return [sys.executable, "-c", "import sys; from colloc.cli import main; sys.exit(main())"]


def simulate(out: Path, seed: int, args: argparse.Namespace) -> Path:
    """The replicate's trial, simulated once (kept in ``out``)."""
    folder = out / f"sim-{seed}"
    trial = folder / "trial"
    if (trial / "metadata.yaml").is_file() or (trial / "metadata.json").is_file():
        return trial
    command = colloc_command() + ["gait", "simulate", "--duration", str(args.duration)]
    command += ["--speed", str(args.speed), "--seed", str(seed)]
    command += ["--motor-noise", str(args.motor_noise), "--out", str(folder)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"simulate seed {seed} failed:\n{done.stderr[-2000:]}")
    return trial


def identify_one(trial: Path, target: Path, design_bound: str, window_strides: int | None) -> None:
    """Identify ``trial`` here and write its estimate, errors and bounds to ``target``."""
    from colloc.identify.gait.settings import GaitIdentifySettings
    from colloc.identify.gait.workflow import identify_gait

    clock = time.perf_counter()
    settings = GaitIdentifySettings(
        trial=trial,
        simulate_validation=False,
        design_bound=design_bound,
        window_strides=window_strides,
    )
    run = identify_gait(settings)
    if run.truth is None:
        raise RuntimeError(f"{trial}: no true controller in its metadata")
    est = run.collocation
    metrics = {k: v for k, v in run.metrics.items() if isinstance(v, int | float)}
    arrays = {
        "K": est.K,
        "Tstar": est.Tstar,
        "K_true": run.truth.K,
        "Tstar_true": run.truth.Tstar,
        "mask": run.mask,
        "K_se": est.K_se if est.K_se is not None else np.full_like(est.K, np.nan),
        "Tstar_se": est.Tstar_se if est.Tstar_se is not None else np.full_like(est.Tstar, np.nan),
    }
    facts = {
        "metrics": metrics,
        "seconds": time.perf_counter() - clock,
        "peak_rss_mb": run.peak_rss_mb,
        "window": list(run.window),
        "notes": run.notes,
    }
    tmp = target.with_suffix(".tmp.npz")
    np.savez(tmp, facts=json.dumps(facts, default=float), **arrays)
    tmp.replace(target)  # a replicate is either whole or absent


def replicate(out: Path, seed: int, args: argparse.Namespace) -> Path:
    """Simulate and identify one replicate in fresh processes (skipped when done)."""
    target = out / f"replicate-{seed}.npz"
    if target.is_file():
        return target
    trial = simulate(out, seed, args)
    command = [sys.executable, __file__, "--one", str(trial), "--target", str(target)]
    command += ["--design-bound", args.design_bound]
    if args.window_strides is not None:
        command += ["--window-strides", str(args.window_strides)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"identify seed {seed} failed:\n{done.stderr[-3000:]}")
    return target


def _interval(values: np.ndarray, statistic, rng: np.random.Generator) -> list[float]:
    """The 2.5 and 97.5 % bootstrap quantiles of ``statistic`` over resampled replicates."""
    n = values.shape[0]
    draws = [statistic(values[rng.integers(0, n, n)]) for _ in range(BOOTSTRAP)]
    return [float(q) for q in np.quantile(draws, [0.025, 0.975])]


def summarise(paths: list[Path]) -> dict:
    """The Monte Carlo figures over the replicates' files (see the module's description)."""
    loaded = [np.load(p) for p in paths]
    facts = [json.loads(str(f["facts"])) for f in loaded]
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    out: dict = {"replicates": len(paths)}
    for name in ("K", "Tstar"):
        est = np.stack([f[name] for f in loaded])
        true = loaded[0][f"{name}_true"]
        if any(not np.allclose(f[f"{name}_true"], true) for f in loaded):
            raise RuntimeError(f"the replicates do not share one true {name}: not one design")
        se = np.stack([f[f"{name}_se"] for f in loaded])
        if name == "K":
            keep = np.broadcast_to(loaded[0]["mask"][None, :, :], true.shape)
        else:
            keep = np.ones(true.shape, dtype=bool)
        scale = float(np.linalg.norm(true))
        err2 = np.array([np.sum((e - true) ** 2) for e in est]) / scale**2
        rows: dict = {"relative_error_rms": float(np.sqrt(err2.mean()))}
        mean = est.mean(axis=0)
        rows["relative_bias"] = float(np.linalg.norm(mean - true) / scale)
        spread2 = np.sum((est - mean) ** 2, axis=tuple(range(1, est.ndim))) / scale**2
        # the bias's own Monte Carlo error: the spread over the root of the replicates
        rows["relative_bias_mc_se"] = float(np.sqrt(spread2.sum() / (len(est) - 1) / len(est)))
        rows["relative_spread"] = float(np.sqrt(spread2.sum() / (len(est) - 1)))
        for kind in ("states_known", "full_design"):
            key = f"{name}_relative_bound_{kind}"
            bounds = np.array([f["metrics"].get(key, np.nan) for f in facts], dtype=float)
            if not np.all(np.isfinite(bounds)):
                continue
            pair = np.column_stack([err2, bounds**2])

            def ratio(v: np.ndarray) -> float:
                return float(np.sqrt(v[:, 0].mean() / v[:, 1].mean()))

            rows[f"bound_{kind}_rms"] = float(np.sqrt(np.mean(bounds**2)))
            rows[f"error_over_bound_{kind}"] = ratio(pair)
            rows[f"error_over_bound_{kind}_interval"] = _interval(pair, ratio, rng)
        sd = est.std(axis=0, ddof=1)
        reported = np.sqrt(np.nanmean(se**2, axis=0))
        usable = keep & (sd > 0) & np.isfinite(reported)
        rows["reported_se_over_spread_median"] = float(np.median(reported[usable] / sd[usable]))
        within = np.abs(est - true) <= 3 * se
        rows["within_3se"] = float(within[np.broadcast_to(keep, est.shape)].mean())
        out[name] = rows
    out["seconds_median"] = float(np.median([f["seconds"] for f in facts]))
    out["peak_rss_mb_max"] = float(max(f["peak_rss_mb"] or 0.0 for f in facts))
    out["per_replicate"] = [
        {
            "file": p.name,
            "seconds": f["seconds"],
            **{
                k: f["metrics"].get(k)
                for k in (
                    "K_relative_error",
                    "Tstar_relative_error",
                    "K_relative_bound_states_known",
                    "K_relative_bound_full_design",
                    "Tstar_relative_bound_full_design",
                    "fraction_within_3se",
                )
            },
        }
        for p, f in zip(paths, facts, strict=True)
    ]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--replicates", type=int, default=12)
    parser.add_argument("--duration", type=float, default=24.0)
    parser.add_argument("--speed", type=float, default=1.1)
    parser.add_argument("--motor-noise", type=float, default=3.0)
    parser.add_argument("--seed-base", type=int, default=500)
    parser.add_argument("--parallel", type=int, default=2, help="replicates at once")
    parser.add_argument("--design-bound", choices=("full", "states-known"), default="full")
    parser.add_argument("--window-strides", type=int, default=None)
    parser.add_argument(
        "--out", type=Path, default=Path(__file__).parent / "results" / "monte_carlo"
    )
    parser.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--target", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        identify_one(args.one, args.target, args.design_bound, args.window_strides)
        return
    if args.replicates < 2:
        parser.error(f"--replicates: expected at least 2, found {args.replicates}")
    args.out.mkdir(parents=True, exist_ok=True)
    seeds = [args.seed_base + r for r in range(args.replicates)]
    clock = time.perf_counter()
    with ThreadPoolExecutor(max_workers=max(1, args.parallel)) as pool:
        paths = list(pool.map(lambda s: replicate(args.out, s, args), seeds))
    record = {
        "design": {
            "duration": args.duration,
            "speed": args.speed,
            "motor_noise": args.motor_noise,
            "seeds": seeds,
            "design_bound": args.design_bound,
            "window_strides": args.window_strides,
        },
        "wall_seconds": time.perf_counter() - clock,
        **summarise(paths),
    }
    append_record(RESULTS, record)


if __name__ == "__main__":
    main()
