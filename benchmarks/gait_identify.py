"""Benchmark ``colloc gait identify``: wall time per step, solver iterations, peak memory and
the recovery of a synthetic trial's controller, one case per fresh process.

    python benchmarks/gait_identify.py --trial DIR [--trial DIR2 ...] \
        [--phase controller heel-strikes] [--max-iter 30] [--duration 90] [--repeat 3] \
        [--process-noise 2,5]

Each case (trial x phase x repeat) runs ``identify_gait`` in its own process, so the peak RSS
is the case's own, and appends one JSON record to ``benchmarks/results/gait_identify.json``:
the settings, the problem size, ``times`` (read / direct / build / solve / uncertainty /
validate seconds), solver status and iterations, ``K_relative_error``,
``Tstar_relative_error`` and their direct-identification twins, ``fraction_within_3se``, the
held-out torque VAF of both controllers, whether the identified controller walks the held-out
part, and the peak RSS. Quote medians over ``--repeat`` runs: the machine is shared.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from results_file import append_record

RESULTS = Path(__file__).parent / "results" / "gait_identify.json"


def one_case(
    trial: Path,
    phase: str,
    max_iter: int,
    duration: float | None,
    fit_fraction: float,
    process_noise: str | None = None,
) -> dict:
    """Run one identification here and return its summary (no store, no figures)."""
    from colloc.identify.gait.outputs import gait_run_id, gait_summary
    from colloc.identify.gait.settings import GaitIdentifySettings
    from colloc.identify.gait.workflow import identify_gait

    settings = GaitIdentifySettings(
        trial=trial,
        phase=phase,
        max_iter=max_iter,
        duration=duration,
        fit_fraction=fit_fraction,
        process_noise=_pair(process_noise),
    )
    run = identify_gait(settings)
    summary = gait_summary(run, gait_run_id(run))
    summary["trial"] = str(trial)
    return summary


def _pair(text: str | None) -> tuple[float, float] | None:
    """``JOINT[,TRUNK]`` as the settings' pair."""
    if text is None:
        return None
    values = [float(v) for v in text.split(",")]
    return (values[0], values[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trial", type=Path, action="append", required=True)
    parser.add_argument("--phase", nargs="+", default=["controller"])
    parser.add_argument("--max-iter", type=int, default=30)
    parser.add_argument("--duration", type=float, default=None, help="fit window [s]")
    parser.add_argument("--fit-fraction", type=float, default=0.75)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--process-noise", default=None, metavar="JOINT[,TRUNK]")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        summary = one_case(
            args.trial[0],
            args.phase[0],
            args.max_iter,
            args.duration,
            args.fit_fraction,
            args.process_noise,
        )
        print(json.dumps(summary))
        return
    for trial in args.trial:
        for phase in args.phase:
            for repeat in range(args.repeat):
                command = [
                    sys.executable, __file__, "--child", "--trial", str(trial),
                    "--phase", phase, "--max-iter", str(args.max_iter),
                    "--fit-fraction", str(args.fit_fraction),
                ]  # fmt: skip
                if args.duration is not None:
                    command += ["--duration", str(args.duration)]
                if args.process_noise is not None:
                    command += ["--process-noise", args.process_noise]
                done = subprocess.run(command, capture_output=True, text=True, check=False)
                if done.returncode != 0:
                    record = {"trial": str(trial), "phase": phase, "error": done.stderr[-2000:]}
                else:
                    record = json.loads(done.stdout.strip().splitlines()[-1])
                record["repeat"] = repeat
                append_record(args.out, record)
                print(
                    f"{trial} {phase} #{repeat}: status {record.get('status')}, iterations "
                    f"{record.get('iterations')}, K error {record.get('K_relative_error')}, "
                    f"walks {record.get('validation', {}).get('walks')}, times "
                    f"{record.get('times')}, peak RSS {record.get('peak_rss_mb')} MB",
                    flush=True,
                )


if __name__ == "__main__":
    main()
