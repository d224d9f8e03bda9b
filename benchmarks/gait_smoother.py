"""Benchmark the gait smoother (:mod:`colloc.identify.gait.smoother`) on a trial window: wall
time and iterations per stage, peak memory, and — given the noise-free twin of the trial
(``colloc gait simulate`` with the same seed and ``--noise 0``) — the smoothed angles, rates
and torques against the truth, with the direct least squares of the controller on the
smoothed signals (at the interval midpoints) against the raw data's and the exact states', and
the default fit's two-stage least squares (instruments: the states one and two samples
earlier, at the nodes) with its bound.

    python benchmarks/gait_smoother.py --trial NOISY --truth CLEAN --start 10 --duration 20 \
        [--repeat 3] [--no-grf] [--scheme midpoint|trapezoidal]

Each case runs in a fresh process (the peak RSS is its own) and appends one JSON record to
``benchmarks/results/gait_smoother.json``. Quote medians over ``--repeat``: the machine is
shared.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from results_file import append_record, peak_rss_mb

RESULTS = Path(__file__).parent / "results" / "gait_smoother.json"


def one_case(
    trial_dir: Path,
    truth_dir: Path | None,
    start: float,
    duration: float,
    grf: bool = True,
    scheme: str = "midpoint",
) -> dict:

    import numpy as np

    from colloc.control.gain_scheduled import GainScheduled
    from colloc.data.columns import TORQUE_COLUMNS
    from colloc.data.trial import read_trial
    from colloc.gait.metadata import STATE_SIGNAL_NAMES
    from colloc.gait.orbit import GaitDynamics
    from colloc.identify.direct import fit_gain_schedule
    from colloc.identify.gait.smoother import GaitSmoother
    from colloc.models.gait2d_params import load_parameters

    clock = time.perf_counter()
    trial = read_trial(trial_dir)
    meta = trial.metadata
    rows = np.flatnonzero((trial.time >= start - 1e-9) & (trial.time <= start + duration + 1e-9))
    dyn = GaitDynamics.build(
        load_parameters(float(meta.get("body_mass", 75.0)), float(meta.get("height", 1.8)))
    )
    setup = time.perf_counter() - clock
    from colloc.identify.gait.smoother_settings import SmootherSettings
    from colloc.transcription import Midpoint, Trapezoidal

    settings = SmootherSettings(scheme={"midpoint": Midpoint, "trapezoidal": Trapezoidal}[scheme]())
    smoother = GaitSmoother.from_trial(dyn, trial, rows, settings, use_ground_reactions=grf)
    # (--no-grf leaves them out; without it they are tracked whatever the scheme)
    result = smoother.run()
    record: dict = {
        "trial": str(trial_dir),
        "start": start,
        "duration": duration,
        "nodes": int(rows.size),
        "scheme": scheme,
        "ground_reactions_tracked": any("grf" in str(y) for y in smoother.model.outputs),
        "setup_seconds": setup,
        "smoother_seconds": sum(s.seconds for s in result.stages),
        "iterations": sum(s.iterations for s in result.stages),
        "stages": [s.__dict__ for s in result.stages],
        "peak_rss_mb": peak_rss_mb(),
    }
    if truth_dir is None:
        return record
    clean = read_trial(truth_dir).signals.iloc[rows]
    noisy = trial.signals.iloc[rows]
    names = list(STATE_SIGNAL_NAMES)
    S_true = clean[names].to_numpy(float)
    T_true = clean[list(TORQUE_COLUMNS)].to_numpy(float)

    def rms(a, b):
        return np.sqrt(np.mean((a - b) ** 2, axis=0))

    def mid(a):
        return 0.5 * (a[1:] + a[:-1])

    record["angle_rms_deg"] = np.degrees(rms(result.states[:, 2:9], S_true[:, 2:9])).tolist()
    record["measured_angle_rms_deg"] = np.degrees(
        rms(noisy[names[2:9]].to_numpy(float), S_true[:, 2:9])
    ).tolist()
    record["midpoint_rate_rms_deg_s"] = np.degrees(
        rms(mid(result.states[:, 11:18]), mid(S_true[:, 11:18]))
    ).tolist()
    record["node_rate_rms_deg_s"] = np.degrees(
        rms(result.states[:, 11:18], S_true[:, 11:18])
    ).tolist()
    record["torque_rms"] = rms(result.torques, T_true).tolist()
    record["residual_rms"] = np.sqrt(np.mean(result.residuals**2, axis=0)).tolist()
    controller = meta.get("controller") or {}
    if {"K", "Tstar", "feedback"} <= set(controller):
        K, Tstar = np.array(controller["K"]), np.array(controller["Tstar"])
        fb = [names.index(n) for n in controller["feedback"]]
        gs = GainScheduled(
            Tstar.shape[0], [dyn.model.states[i] for i in fb], dyn.gait.torques, structure="full"
        )
        phase = noisy["controller_phase"].to_numpy(float)
        S = noisy[names].to_numpy(float)
        T = noisy[list(TORQUE_COLUMNS)].to_numpy(float)

        def errors(p, s, torque):
            fit = fit_gain_schedule(gs, p, s[:, fb], torque)
            return {
                "K": float(np.linalg.norm(fit.K - K) / np.linalg.norm(K)),
                "Tstar": float(np.linalg.norm(fit.Tstar - Tstar) / np.linalg.norm(Tstar)),
            }

        at_t, at_states, at_torques = result.at_dynamics()
        record["controller_least_squares"] = {
            "raw": errors(phase, S, T),
            "smoothed": errors(np.interp(at_t, result.times, phase), at_states, at_torques),
            "exact_states_measured_torques": errors(phase, S_true, T),
        }
        from colloc.identify.gait.controller_fit import fit_schedule_with_errors, relative_spread
        from colloc.identify.gait.settings import DEFAULT_INSTRUMENT_LAGS

        strides = np.searchsorted(trial.right_heel_strikes, result.times)

        def instrumented(s, torque):
            est = fit_schedule_with_errors(
                gs, phase, s[:, fb], torque, strides, instrument_lags=DEFAULT_INSTRUMENT_LAGS
            )
            return {
                "method": est.method,
                "K": float(np.linalg.norm(est.K - K) / np.linalg.norm(K)),
                "Tstar": float(np.linalg.norm(est.Tstar - Tstar) / np.linalg.norm(Tstar)),
                "K_bound": relative_spread(est.K_bound, K),
                "within_3se": float(
                    np.mean(
                        np.abs(np.append(est.K - K, est.Tstar - Tstar))
                        <= 3 * np.append(est.K_se, est.Tstar_se)
                    )
                ),
            }

        record["controller_instrumented"] = {
            "smoothed_nodes": instrumented(result.states, result.torques),
            "exact_states_measured_torques": instrumented(S_true, T),
        }
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trial", type=Path, required=True)
    parser.add_argument("--truth", type=Path)
    parser.add_argument("--start", type=float, default=10.0)
    parser.add_argument("--duration", type=float, nargs="+", default=[20.0])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument(
        "--scheme",
        choices=("midpoint", "trapezoidal"),
        default="midpoint",
        help="the smoother's second-order scheme",
    )
    parser.add_argument(
        "--no-grf", action="store_true", help="leave the trial's ground reactions out"
    )
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        record = one_case(
            args.trial, args.truth, args.start, args.duration[0], not args.no_grf, args.scheme
        )
        print(json.dumps(record))
        return
    for duration in args.duration:
        for _ in range(args.repeat):
            command = [sys.executable, __file__, "--one", "--trial", str(args.trial)]
            command += ["--start", str(args.start), "--duration", str(duration)]
            if args.truth:
                command += ["--truth", str(args.truth)]
            if args.no_grf:
                command.append("--no-grf")
            command += ["--scheme", args.scheme]
            out = subprocess.run(command, capture_output=True, text=True, check=True)
            record = json.loads(out.stdout.strip().splitlines()[-1])
            append_record(RESULTS, record)
            print(
                f"{duration:5.0f} s: {record['smoother_seconds']:6.1f} s smoothing, "
                f"{record['iterations']} iterations, {record['peak_rss_mb']:.0f} MB"
                + (
                    "; least squares K error raw / smoothed / exact states: "
                    + " / ".join(
                        f"{v['K']:.2f}" for v in record["controller_least_squares"].values()
                    )
                    if "controller_least_squares" in record
                    else ""
                )
            )


if __name__ == "__main__":
    main()
