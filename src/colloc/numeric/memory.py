"""Peak resident memory of this process and of the solver processes it forked."""

from __future__ import annotations

import resource


def peak_rss_mb() -> float:
    """Peak resident memory [MB] of this process or of its largest finished child.

    colloc solves IPOPT in a forked child (:mod:`colloc.solve.watchdog`), whose factors the
    parent never holds: the process's own peak alone misses the solve's memory.

    Returns
    -------
    float
    """
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, children) / 1024
