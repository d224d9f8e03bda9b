"""Benchmark of the periodic walking cycle (``colloc.gait.find_walking_cycle``).

Runs the default settings (1.2 m/s, 60 nodes, backward Euler, soft-contact stage then the
real contact) with a cold build cache and again with the warm cache, and optionally a
scheme comparison. Reports derive / build / solve time, IPOPT iterations per stage, RMS
joint-angle error against Winter and the peak vertical GRF in body weights.

Usage: python benchmarks/gait_cycle.py [--num-nodes 60] [--speed 1.2] [--midpoint]
                                       [--out benchmarks/results/gait_cycle.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from colloc.gait import find_walking_cycle
from colloc.gait.cycle import _plant
from colloc.models.gait2d_params import load_parameters
from colloc.transcription import BackwardEuler, Midpoint


def run(speed: float, num_nodes: int, scheme, cache_dir: str) -> dict:
    """One solve with the given settings; timings and the quality measures."""
    t0 = time.perf_counter()
    cycle = find_walking_cycle(speed, num_nodes, scheme=scheme, cache=cache_dir)
    total = time.perf_counter() - t0
    stages = cycle.stats["stages"]
    params = load_parameters()
    mean_fy = np.mean(cycle.contact_forces[1:, 1::2].sum(axis=1))
    return {
        "scheme": type(scheme).__name__,
        "speed": speed,
        "num_nodes": num_nodes,
        "duration": cycle.duration,
        "total_time": total,
        "build_time": sum(s["build_time"] for s in stages),
        "solve_time": sum(s["solve_time"] for s in stages),
        "iterations": [s["iterations"] for s in stages],
        "stages": stages,
        "rms_angle_error_deg": cycle.stats["rms_angle_error_deg"],
        "rms_angle_error_by_joint_deg": cycle.stats["rms_angle_error_by_joint_deg"],
        "peak_vertical_grf_bw": cycle.stats["peak_vertical_grf_bw"],
        "mean_vertical_force_over_weight": float(mean_fy / (params.total_mass * params.gravity)),
        "hip_height_range_m": [float(cycle.states[:, 1].min()), float(cycle.states[:, 1].max())],
        "peak_abs_torque_nm": np.abs(cycle.torques).max(axis=0).round(2).tolist(),
    }


def main() -> None:
    """Run the cases, print them and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-nodes", type=int, default=60)
    parser.add_argument("--speed", type=float, default=1.2)
    parser.add_argument("--midpoint", action="store_true", help="also run Midpoint")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/gait_cycle.json"))
    args = parser.parse_args()
    t0 = time.perf_counter()
    _plant()
    derive_time = time.perf_counter() - t0
    cases = []
    with tempfile.TemporaryDirectory() as cache_dir:
        for label in ("cold cache", "warm cache"):
            case = {"case": label, "derive_time": derive_time} | run(
                args.speed, args.num_nodes, BackwardEuler(), cache_dir
            )
            cases.append(case)
            print(json.dumps(case, indent=2))
        if args.midpoint:
            try:
                case = {"case": "midpoint"} | run(args.speed, args.num_nodes, Midpoint(), cache_dir)
            except RuntimeError as exc:
                case = {"case": "midpoint", "error": str(exc)}
            cases.append(case)
            print(json.dumps(case, indent=2))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"cases": cases}, indent=2))


if __name__ == "__main__":
    main()
