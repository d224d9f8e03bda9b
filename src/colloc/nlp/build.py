"""Build (or load from the disk cache) the differentiated templates of a problem."""

from __future__ import annotations

import functools
import hashlib
import logging
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import sympy as sm

from colloc.model.symbols import name_of
from colloc.nlp.objective import NodeTerm
from colloc.nlp.templates import (
    Partition,
    instance_template,
    interval_template,
    node_template,
    objective_template,
    residual_function,
)
from colloc.numeric.cache import BuildCache, cache_key, expression_digest
from colloc.numeric.stencil import StencilFunctions
from colloc.transcription.base import Scheme

logger = logging.getLogger(__name__)

#: Bumped whenever a template's arguments change, so functions cached by an older colloc are
#: rebuilt instead of being called with the wrong layout (2: the objective takes the
#: schedules' slots, for tracked controller outputs; 3: and a Gauss-Newton switch).
_VERSION = "3"

#: The code that decides what a built function computes and takes: its source is part of
#: every cache key, so an entry built by other code (an edit without a version bump, an
#: older install) is never called with the wrong layout (issue 13: "index 12 is out of
#: bounds for axis 1 with size 12", from a stale entry).
_BUILD_SOURCES = (
    "numeric",
    "transcription",
    "nlp/build.py",
    "nlp/templates.py",
    "nlp/objective.py",
    "nlp/placement.py",
)


@functools.cache
def _source_digest() -> str:
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for name in _BUILD_SOURCES:
        target = root / name
        for path in sorted(target.glob("*.py")) if target.is_dir() else [target]:
            h.update(path.relative_to(root).as_posix().encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def _fingerprint(
    part: Partition,
    scheme: Scheme,
    terms: Sequence[NodeTerm],
    ic_exprs: Sequence[sm.Expr],
    ic_vars: Sequence[sm.Symbol],
) -> list[str]:
    m = part.model
    return [
        f"colloc-build={_VERSION}",
        f"source={_source_digest()}",
        "residual=" + expression_digest(list(m.residual)),
        "states=" + ",".join(sm.srepr(x) for x in m.states),
        "inputs=" + ",".join(sm.srepr(r) for r in m.inputs),
        "params=" + ",".join(sm.srepr(p) for p in m.parameters),
        "free_inputs=" + ",".join(name_of(r) for r in part.free_inputs),
        "known_inputs=" + ",".join(name_of(r) for r in part.known_inputs),
        "unknown=" + ",".join(name_of(p) for p in part.unknown_parameters),
        f"scheme={scheme.name}",
        "objective="
        + expression_digest([t.expr for t in terms])
        + repr([t.data_symbols for t in terms]),
        "instance=" + expression_digest(list(ic_exprs)) + repr(list(ic_vars)),
        "schedules=" + repr([(s.slots_a, s.slots_b, s.weight, s.phase) for s in m.schedules]),
    ]


def build_templates(
    part: Partition,
    scheme: Scheme,
    terms: Sequence[NodeTerm],
    ic_exprs: Sequence[sm.Expr],
    ic_vars: Sequence[sm.Symbol],
    cache: bool | str | Path | Any = True,
) -> tuple[dict[str, StencilFunctions | None], bool]:
    """The interval, node, objective and instance templates of a problem.

    Parameters
    ----------
    part : Partition
    scheme : Scheme
    terms : sequence of NodeTerm
    ic_exprs, ic_vars : instance constraints in placeholders
    cache : bool or path
        ``True``: the default cache directory; a path: that directory; ``False``: none.

    Returns
    -------
    templates : dict
        ``"interval"``, ``"node"``, ``"objective"``, ``"instance"`` (``None`` when absent).
    cache_hit : bool
    """
    store = None
    if cache is not False and cache is not None:
        store = BuildCache(None if cache is True else cache)
        key = cache_key(_fingerprint(part, scheme, terms, ic_exprs, ic_vars))
        entry = store.get(key)
        if entry is not None:
            try:
                return {
                    k: None if v is None else StencilFunctions.from_bytes(v)
                    for k, v in entry.items()
                }, True
            except Exception as exc:  # a stale, corrupt or foreign entry is rebuilt, never fatal
                warnings.warn(
                    f"build cache entry {store.path(key)} not used, rebuilding: {exc}",
                    UserWarning,
                    stacklevel=4,
                )
    F = residual_function(part.model)
    templates: dict[str, StencilFunctions | None] = {
        "interval": interval_template(part, scheme, F),
        "node": node_template(part, scheme, F),
        "objective": objective_template(part, scheme, terms) if terms else None,
        "instance": instance_template(part, ic_exprs, ic_vars) if ic_exprs else None,
    }
    if store is not None:
        store.put(key, {k: None if v is None else v.to_bytes() for k, v in templates.items()})
    return templates, False
