"""The batch bar: ``colloc pendulum -n 1 -d 60 -s 100 -r -i close --repeat 100`` on this machine.

Runs the command in a fresh process against a new SQLite file, then reads the batch record:
wall time of the whole command, each run's time in its worker, their sum, and the bar's
ratio ``wall / (sum of run times / workers)`` (at most 1.2 to pass: both cores busy, the
build paid once per worker). Also the per-gain report (spread over mean standard error) and the
peak memory of the largest process.

Usage: python benchmarks/batch_repeat.py [--repeat 100] [--workers 2]
       [--out benchmarks/results/batch_repeat.json]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    """Run the command once and write the figures as JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/batch_repeat.json"))
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="colloc-batch-"))
    url = f"sqlite:///{folder / 'runs.db'}"
    command = [
        str(Path(sys.executable).with_name("colloc")),
        *"pendulum -n 1 -d 60 -s 100 -r -i close".split(),
        "--repeat",
        str(args.repeat),
        "--workers",
        str(args.workers),
        "--db",
        url,
        "--out",
        str(folder / "out"),
    ]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(done.stdout[-3000:])
    if done.returncode != 0:
        print(done.stderr[-3000:], file=sys.stderr)
        sys.exit(done.returncode)

    from colloc.batch.report import pendulum_table
    from colloc.store import RunStore

    with RunStore(url) as store:
        (batch_id,) = store.batches.list()["batch_id"]
        entries = store.batches.get(batch_id)["entries"]
        run_ids = list(entries["run_id"])
        table = pendulum_table(store, run_ids)
    seconds = [float(s) for s in entries["seconds"]]
    busy = sum(seconds)
    result = {
        "command": " ".join(command[1:]),
        "runs": len(entries),
        "stored": int((entries["status"] == "done").sum()),
        "workers": args.workers,
        "wall_seconds": wall,
        "sum_run_seconds": busy,
        "median_run_seconds": statistics.median(seconds),
        "first_run_seconds": seconds[: args.workers],
        "bar_ratio_wall_over_sum_per_worker": wall / (busy / args.workers),
        "bar": "<= 1.2",
        "peak_rss_mb_largest_process": peak_mb,
        "spread_over_se": dict(zip(table["gain"], table["spread_over_se"], strict=True)),
        "within_3se": dict(zip(table["gain"], table["within_3se"], strict=True)),
    }
    print(json.dumps(result, indent=2))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
