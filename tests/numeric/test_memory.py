"""peak_rss_mb counts a forked solver's memory, which the process's own peak never holds."""

from __future__ import annotations

import json
import subprocess
import sys

# in a fresh interpreter, whose own peak is small: a forked child touches 300 MB more
SCRIPT = """
import json, multiprocessing, resource
import numpy as np
from colloc.numeric.memory import peak_rss_mb

def allocate(megabytes):
    block = np.ones(megabytes * 2**20 // 8)
    assert block.sum() > 0

before = peak_rss_mb()
extra = int(before) + 300
child = multiprocessing.get_context("fork").Process(target=allocate, args=(extra,))
child.start()
child.join()
print(json.dumps({
    "before": before, "extra": extra, "after": peak_rss_mb(), "code": child.exitcode,
    "own": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
}))
"""


def test_a_forked_childs_peak_counts_and_the_parents_own_does_not_see_it():
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, check=True, timeout=120
    )
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["code"] == 0
    assert found["after"] >= found["extra"] > found["before"]
    assert found["own"] < found["extra"]  # the parent never held the child's block
