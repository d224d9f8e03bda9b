"""Run the test cases CI skips (``@pytest.mark.slow``) and record each one's outcome and time.

CI keeps under its 15 minutes by leaving out the cases that take a minute or more each (the
whole gait identification on two Dask workers, Monte Carlo studies of the error bars, the
gallery and docs examples run whole, the walks and cycles of minutes). They are cases like
any other, not benchmarks of speed: this script runs them all (or those ``-k`` selects) in
one pytest process and appends one record to ``benchmarks/results/slow_tests.json`` with
each case's outcome and seconds, the totals and the commit.

    python benchmarks/slow_tests.py [-k EXPRESSION]

The exit status is pytest's: 0 when every selected case passed.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from pathlib import Path

from results_file import append_record

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).parent / "results" / "slow_tests.json"


def _cases(report: Path) -> list[dict[str, object]]:
    """Each test case of a JUnit XML report: its name, outcome and seconds."""
    cases = []
    for case in ElementTree.parse(report).getroot().iter("testcase"):
        outcome = "passed"
        for kind in ("failure", "error", "skipped"):
            if case.find(kind) is not None:
                outcome = {"failure": "failed"}.get(kind, kind)
        cases.append(
            {
                "case": f"{case.get('classname')}::{case.get('name')}",
                "outcome": outcome,
                "seconds": round(float(case.get("time") or 0.0), 2),
            }
        )
    return cases


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-k", dest="select", default=None, help="pytest -k expression")
    args = parser.parse_args()
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT
    ).stdout.strip()
    with tempfile.TemporaryDirectory() as folder:
        report = Path(folder) / "slow.xml"
        command = [sys.executable, "-m", "pytest", "-m", "slow", "-q", f"--junitxml={report}"]
        if args.select:
            command += ["-k", args.select]
        started = time.perf_counter()
        status = subprocess.run(command, cwd=ROOT).returncode
        wall = time.perf_counter() - started
        cases = _cases(report) if report.is_file() else []
    append_record(
        RESULTS,
        {
            "commit": commit,
            "selection": args.select,
            "exit_status": status,
            "wall_seconds": round(wall, 1),
            "passed": sum(c["outcome"] == "passed" for c in cases),
            "failed": [c["case"] for c in cases if c["outcome"] in ("failed", "error")],
            "cases": cases,
        },
    )
    return status


if __name__ == "__main__":
    sys.exit(main())
