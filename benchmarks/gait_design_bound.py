"""The whole design's Cramer-Rao bound of a gait controller beside the states-known one.

On a stretch of a synthetic trial with motor noise (its true controller in the metadata),
evaluated at the trial's own noisy states and the true schedule:

* **states known**: the schedule's least squares ``T = T*(phi) - K(phi) s + e`` on the
  recorded states, ``e`` the torque measurement and motor noise combined
  (:func:`colloc.identify.gait.controller_fit.fit_schedule_with_errors`);
* **whole design**: the closed loop's maximum a posteriori problem, the states unknown, the
  trial's angles, trunk pose and torques tracked at their noise and the motor noise a
  penalised residual, the states eliminated piece by piece
  (:mod:`colloc.identify.gait.design_bound`);
* with ``--lab-trial`` (the trial ``colloc gait trial-from-lab`` made of the same walk's lab
  export), **the lab's design**: the same closed loop tracking the lab's markers, with and
  without its plates, and no torques (the marker smoother's design: its markers' places,
  segment lengths, noise levels and trapezoidal rule), at the same states. What a lab loses by
  not measuring torques, and what the plates give back.

::

    python benchmarks/gait_design_bound.py --trial DIR --start 3 --duration 20 \
        [--lab-trial LAB] [--piece-nodes 50] [--states-known-only] [--noise-of NOISY] \
        [--out FILE]

The bounds are taken at the states of the trial given: give the noise-free twin (``colloc
gait simulate`` with the same seed and motor noise and ``--noise 0``) for the exact states.
At a noisy trial's states the noisy rates read as excitation of the feedback and the plates'
Jacobian is taken where the noisy feet are: on 27 s of a 1.05 m/s walk every bound came out
2-3.4 times narrower than at the twin's (K states known 19.8 against 66.3 %).

Prints and appends to ``benchmarks/results/gait_design_bound.json``: both relative bounds of
``K`` and ``T*`` (``sqrt(sum var) / |truth|``), their ratio, the pieces, the wall time of the
whole-design bound and the peak memory.
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np
from results_file import append_record

from colloc.control.gain_scheduled import GainScheduled
from colloc.data.columns import TORQUE_COLUMNS
from colloc.data.split import take_rows
from colloc.data.trial import read_trial
from colloc.identify.gait.controller_fit import fit_schedule_with_errors, relative_spread
from colloc.identify.gait.design_bound import PIECE_NODES, BoundJob, WindowDesign, full_design_bound
from colloc.identify.gait.phase_law import phase_law
from colloc.identify.gait.read import state_names, subject, tracked_columns
from colloc.identify.gait.settings import DEFAULT_TRACK
from colloc.identify.gait.trial_noise import (
    recorded_motor_noise,
    torque_equation_noise,
    trial_noise_std,
)
from colloc.identify.gait.windows import gait_dynamics

RESULTS = Path(__file__).parent / "results" / "gait_design_bound.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trial", type=Path, required=True)
    parser.add_argument("--start", type=float, default=0.0, help="s from the record's start")
    parser.add_argument("--duration", type=float, required=True, help="s of record")
    parser.add_argument("--piece-nodes", type=int, default=PIECE_NODES)
    parser.add_argument("--lab-trial", type=Path, help="the same walk's trial-from-lab trial")
    parser.add_argument(
        "--states-known-only",
        action="store_true",
        help="only the states-known bound (the regression's, seconds at any length)",
    )
    parser.add_argument(
        "--noise-of",
        type=Path,
        help="take the torque equation's noise from this trial's metadata (the noisy trial "
        "whose noise-free twin --trial is: the noise an identification of it assumes)",
    )
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    trial = read_trial(args.trial)
    meta = trial.metadata
    motor = recorded_motor_noise(meta) or 0.0
    if motor <= 0:
        raise SystemExit("the trial records no motor noise: the whole design's bound needs it")
    controller = meta["controller"]
    Tstar, K = np.asarray(controller["Tstar"], float), np.asarray(controller["K"], float)
    dyn = gait_dynamics(*subject(meta))
    names = list(state_names())
    feedback = [names.index(n) for n in controller["feedback"]]
    gs = GainScheduled(
        Tstar.shape[0],
        [dyn.model.states[i] for i in feedback],
        dyn.gait.torques,
        structure=np.asarray(controller["mask"], dtype=bool),
    )
    law = phase_law("causal", trial)
    rows = np.flatnonzero((trial.time >= args.start) & (trial.time < args.start + args.duration))
    part = take_rows(trial, rows)
    signals, t = part.signals, part.time
    states = signals[names].to_numpy(dtype=float)
    torques = signals[list(TORQUE_COLUMNS)].to_numpy(dtype=float)
    phase = law.at(t, signals)

    noise_meta = read_trial(args.noise_of).metadata if args.noise_of is not None else meta
    strides = np.searchsorted(trial.right_heel_strikes, t)
    known = fit_schedule_with_errors(
        gs,
        phase,
        states[:, feedback],
        torques,
        strides,
        np.full(len(TORQUE_COLUMNS), torque_equation_noise(noise_meta)),
    )
    record = {
        "trial": str(args.trial),
        "noise_of": str(args.noise_of) if args.noise_of is not None else None,
        "start": args.start,
        "duration": args.duration,
        "samples": int(t.size),
        "motor_noise": motor,
        "torque_equation_noise": torque_equation_noise(noise_meta),
        "K_relative_bound_states_known": relative_spread(known.K_bound, K),
        "Tstar_relative_bound_states_known": relative_spread(known.Tstar_bound, Tstar),
    }
    if args.states_known_only:
        append_record(args.out, record)
        return

    start = time.perf_counter()
    noise = {c: trial_noise_std(meta, c) for c in tracked_columns(DEFAULT_TRACK)}
    window = WindowDesign(t, states, torques, signals["belt_speed"].to_numpy(float), phase)
    job = BoundJob(
        subject(meta),
        Tstar.shape[0],
        tuple(feedback),
        np.asarray(controller["mask"], dtype=bool),
        tuple(noise.items()),
        motor,
        window,
        Tstar,
        K,
        args.piece_nodes,
    )
    Tb_full, Kb_full, count = full_design_bound(gs, [job])
    seconds = time.perf_counter() - start
    record |= {
        "pieces": count,
        "piece_nodes": args.piece_nodes,
        "K_relative_bound_full_design": relative_spread(Kb_full, K),
        "Tstar_relative_bound_full_design": relative_spread(Tb_full, Tstar),
        "full_design_seconds": seconds,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }
    record["K_ratio"] = (
        record["K_relative_bound_full_design"] / record["K_relative_bound_states_known"]
    )
    record["Tstar_ratio"] = (
        record["Tstar_relative_bound_full_design"] / record["Tstar_relative_bound_states_known"]
    )
    if args.lab_trial is not None:
        record |= lab_bounds(args, job, gs, Tstar, K)
    append_record(args.out, record)


def lab_bounds(
    args: argparse.Namespace, job: BoundJob, gs: GainScheduled, Tstar: np.ndarray, K: np.ndarray
) -> dict:
    """The lab design's bounds (markers and plates; markers alone) at the job's states, over
    the samples the lab trial kept."""
    from dataclasses import replace

    from colloc.identify.gait.design_bound import lab_signals
    from colloc.identify.gait.markers import marker_smoother
    from colloc.transcription import Trapezoidal

    lab = read_trial(args.lab_trial)
    window = job.window
    kept = np.isin(np.round(lab.time, 6), np.round(window.times, 6))
    rows = np.flatnonzero(kept)
    ours = np.isin(np.round(window.times, 6), np.round(lab.time[rows], 6))
    _, facts = marker_smoother(gait_dynamics(*job.body), lab, rows)
    signals, (observed,) = lab_signals(lab, [facts], [lab.time[rows]])
    markers = 2 * len(signals.segments)
    cases = {
        "markers_and_plates": (signals, observed),
        "markers_alone": (replace(signals, plate_std=None), observed[:, :markers]),
    }
    out: dict = {"lab_trial": str(args.lab_trial), "lab_samples": int(rows.size)}
    for name, (design, seen) in cases.items():
        start = time.perf_counter()
        part = WindowDesign(
            window.times[ours],
            window.states[ours],
            window.torques[ours],
            window.belt_speed[ours],
            window.phase[ours],
            seen,
        )
        lab_job = replace(job, noise=(), window=part, lab=design, scheme=Trapezoidal)
        Tb, Kb, _ = full_design_bound(gs, [lab_job])
        out[f"K_relative_bound_{name}"] = relative_spread(Kb, K)
        out[f"Tstar_relative_bound_{name}"] = relative_spread(Tb, Tstar)
        out[f"{name}_seconds"] = time.perf_counter() - start
        print(f"{name}: K bound {out[f'K_relative_bound_{name}']:.1%}, T* "
              f"{out[f'Tstar_relative_bound_{name}']:.1%} ({out[f'{name}_seconds']:.0f} s)")  # fmt: skip
    return out


if __name__ == "__main__":
    main()
