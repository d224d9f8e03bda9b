"""Start-up and whole-process time: colloc against the hand-written CasADi script, in one run.

Each figure is the median of ``--repeats`` fresh processes (the two commands of a pair run
back to back, so machine load hits both alike):

- ``import colloc`` (``python -c "import colloc"``) and ``colloc --help``, and which of pandas,
  matplotlib, SQLAlchemy and colloc's plot/store layers they load (none should be);
- the seed case, ``colloc pendulum -n 1 -d 60 -s 100 -r -i close --no-store``, against
  ``benchmarks/casadi_pendulum.py -n 1 -i close`` (same study written by hand in CasADi):
  whole-process wall seconds and their ratio;
- with ``--links 4``: the 4-link identification ('direct' gain guess) by both, build and solve
  seconds from each run's own timers and their ratios.

    python benchmarks/startup.py --repeats 5 [--links 1 4]

Appends one JSON record to ``benchmarks/results/startup.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from results_file import append_record

HERE = Path(__file__).parent
RESULTS = HERE / "results" / "startup.json"
PYTHON = sys.executable
COLLOC = str(Path(PYTHON).parent / "colloc")
HEAVY = ("pandas", "matplotlib", "sqlalchemy", "colloc.plot", "colloc.store.runs")


def wall(command: list[str]) -> tuple[float, str]:
    """Wall seconds of one process and its standard output."""
    t0 = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=True)
    return time.perf_counter() - t0, done.stdout


def median_wall(command: list[str], repeats: int) -> float:
    """Median wall seconds of ``repeats`` runs."""
    return statistics.median(wall(command)[0] for _ in range(repeats))


def loaded_by(setup: str) -> list[str]:
    """Which heavy modules a fresh interpreter holds after running ``setup``."""
    code = (
        f"import json, sys; {setup}; print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    return json.loads(wall([PYTHON, "-c", code])[1])


def pair(links: int, repeats: int) -> dict:
    """colloc and the CasADi script on the same study, ``repeats`` times each, interleaved."""
    guess = "close" if links == 1 else "direct"
    rows: dict[str, list] = {"colloc": [], "casadi": []}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.json"
        colloc = [COLLOC, "pendulum", "-n", str(links), "-d", "60", "-s", "100", "-r"]
        colloc += ["-i", guess, "--no-store", "--json", str(out)]
        casadi = [PYTHON, str(HERE / "casadi_pendulum.py"), "-n", str(links), "-i", guess]
        casadi += ["--json", str(out)]
        for _ in range(repeats):
            for name, command in (("colloc", colloc), ("casadi", casadi)):
                seconds, _ = wall(command)
                record = json.loads(out.read_text())
                rows[name].append({"process": seconds, **record["times"]})
    summary: dict = {"links": links, "guess": guess, "repeats": repeats}
    for name, runs in rows.items():
        summary[name] = {
            key: statistics.median(r[key] for r in runs) for key in ("process", "build", "solve")
        }
    summary["process_ratio"] = summary["colloc"]["process"] / summary["casadi"]["process"]
    summary["build_ratio"] = summary["casadi"]["build"] / summary["colloc"]["build"]
    summary["solve_ratio"] = summary["colloc"]["solve"] / summary["casadi"]["solve"]
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--links", type=int, nargs="+", default=[1])
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    record = {
        "import_colloc_seconds": median_wall([PYTHON, "-c", "import colloc"], args.repeats),
        "colloc_help_seconds": median_wall([COLLOC, "--help"], args.repeats),
        "loaded_by_import": loaded_by("import colloc"),
        "loaded_by_help": loaded_by("from colloc.cli import build_parser; build_parser()"),
        "pendulum": [pair(links, args.repeats) for links in args.links],
    }
    print(json.dumps(record, indent=1))
    append_record(args.out, record)


if __name__ == "__main__":
    main()
