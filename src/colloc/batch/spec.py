"""A batch file: a YAML list of runs, with sweeps, expanded into one entry per run.

The file is a mapping with a list ``runs`` (and optionally ``db``, the results database, and
``workers``)::

    db: sqlite:///noise-study.db
    runs:
      - kind: pendulum
        numlinks: 1
        sensornoise: true
        seed: {range: [0, 100]}
      - kind: gait-simulate
        duration: 60
        seed: {values: [1, 2]}
        out: "trials/seed-{seed}"
      - kind: gait-identify
        trial: {glob: "trials/seed-*"}

Each run's keys are the long options of its command (``colloc pendulum``, ``colloc gait
simulate``, ``colloc gait identify``) without the dashes; a flag is ``true`` or ``false``.
A value ``{range: [start, stop]}`` (or ``[start, stop, step]``, integers, stop excluded),
``{values: [...]}`` or ``{glob: "pattern"}`` (sorted matches, relative to the working folder)
sweeps the key: a run with several sweeps is repeated for every combination. Strings may
name the run's other keys in braces (``"trials/seed-{seed}"``).
"""

from __future__ import annotations

import glob as globbing
import itertools
import math
import os
import string
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from colloc.data.yaml_io import safe_load_unique

#: Most entries one batch may expand to.
MAX_ENTRIES = 100_000

#: Keys a sweep may use, and what each expands to.
SWEEPS = ("range", "values", "glob")

#: Top-level keys of a batch file.
TOP_KEYS = ("runs", "db", "workers")


class BatchSpecError(ValueError):
    """A batch file or one of its entries has problems (all are listed)."""

    def __init__(self, problems: list[str], where: str, partial: BatchSpec | None = None) -> None:
        self.problems = list(problems)
        #: The entries that did expand (None when the file itself is unreadable), so a
        #: caller can check them too and report every problem at once.
        self.partial = partial
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"{where} has {len(self.problems)} problem(s):\n{lines}")


@dataclass(frozen=True)
class Entry:
    """One run of a batch, as written (sweeps expanded).

    Attributes
    ----------
    position : int
        Index among the expanded entries.
    source : int
        Index of the run in the file's ``runs`` list.
    kind : str
        ``"pendulum"``, ``"gait-simulate"`` or ``"gait-identify"``.
    options : dict
        The run's options, keys with dashes (``"noise-std"``), values as written.
    """

    position: int
    source: int
    kind: str
    options: dict[str, Any] = field(default_factory=dict)

    def where(self) -> str:
        """How problems name this entry."""
        return f"runs[{self.source}] ({self.kind}, entry {self.position})"


@dataclass(frozen=True)
class BatchSpec:
    """A batch file, read and expanded.

    Attributes
    ----------
    entries : list of Entry
    db : str or None
        The file's results database, if it names one.
    workers : int or None
        The file's number of workers, if it gives one.
    source : dict
        The file as read (for the batch record).
    """

    entries: list[Entry]
    db: str | None = None
    workers: int | None = None
    source: dict[str, Any] = field(default_factory=dict)


def read_batch_spec(path: str | os.PathLike[str], kinds: tuple[str, ...]) -> BatchSpec:
    """Read a batch file and expand its sweeps.

    Parameters
    ----------
    path : path-like
        The YAML file (read with ``yaml.safe_load``).
    kinds : tuple of str
        The run kinds the caller can run.

    Returns
    -------
    BatchSpec

    Raises
    ------
    BatchSpecError
        Listing every problem of the file at once, each naming the run (``runs[i]``) and
        key: not a mapping, unknown top-level keys, no runs, an unknown kind, a malformed
        sweep, a template naming no key, too many entries. Its ``partial`` holds the
        entries that did expand.
    """
    where = f"batch file {shown_path(path)}"
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise BatchSpecError([f"not UTF-8 text (byte {error.start})"], where) from error
    except OSError as error:
        raise BatchSpecError([f"cannot be read ({error.strerror or error})"], where) from error
    try:
        raw = safe_load_unique(text)
    except yaml.YAMLError as error:
        raise BatchSpecError([f"not valid YAML ({error})"], where) from error
    return expand_batch(raw, kinds, where)


def shown_path(path: str | os.PathLike[str], limit: int = 120) -> str:
    """A path as messages show it: quoted, and cut in the middle when longer than ``limit``.

    Parameters
    ----------
    path : path-like
    limit : int, optional

    Returns
    -------
    str
    """
    text = os.fspath(path)
    if len(text) <= limit:
        return repr(text)
    keep = limit // 2
    return f"{text[:keep]!r}...{text[-keep:]!r} ({len(text)} characters)"


def expand_batch(raw: Any, kinds: tuple[str, ...], where: str = "batch") -> BatchSpec:
    """Expand a batch read from YAML (see :func:`read_batch_spec`).

    Parameters
    ----------
    raw : Any
        What ``yaml.safe_load`` gave.
    kinds : tuple of str
        The run kinds the caller can run.
    where : str
        How errors name the batch.

    Returns
    -------
    BatchSpec

    Raises
    ------
    BatchSpecError
        Listing every problem at once.
    """
    if not isinstance(raw, Mapping):
        raise BatchSpecError(
            [f"expected a mapping with a list 'runs', found {type(raw).__name__}"], where
        )
    problems = [
        f"{key!r}: unknown key (expected {list(TOP_KEYS)})" for key in raw if key not in TOP_KEYS
    ]
    runs = raw.get("runs")
    if not isinstance(runs, list) or not runs:
        problems.append(f"runs: expected a non-empty list of runs, found {runs!r}")
        runs = []
    db = raw.get("db")
    if db is not None and (not isinstance(db, str) or not db.strip()):
        problems.append(f"db: expected a database URL string, found {db!r}")
    workers = raw.get("workers")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        problems.append(f"workers: expected an integer >= 1, found {workers!r}")
    entries: list[Entry] = []
    for source, run in enumerate(runs):
        for options in _expand_run(run, source, kinds, problems, MAX_ENTRIES - len(entries)):
            kind = options.pop("kind")
            entries.append(Entry(len(entries), source, kind, options))
    spec = BatchSpec(entries, db, workers, dict(raw))
    if problems:
        raise BatchSpecError(problems, where, spec)
    return spec


def _expand_run(
    run: Any, source: int, kinds: tuple[str, ...], problems: list[str], room: int
) -> list[dict[str, Any]]:
    """The option mappings of one run, one per combination of its sweeps (counted first: more
    than ``room`` is a problem, and nothing is built)."""
    name = f"runs[{source}]"
    if not isinstance(run, Mapping):
        problems.append(f"{name}: expected a mapping of options, found {run!r}")
        return []
    kind = run.get("kind")
    if kind not in kinds:
        problems.append(f"{name}.kind: expected one of {list(kinds)}, found {kind!r}")
        return []
    fixed: dict[str, Any] = {}
    swept: dict[str, list[Any]] = {}
    before = len(problems)
    for key, value in run.items():
        if not isinstance(key, str) or not key:
            problems.append(f"{name}: option names are strings, found {key!r}")
            continue
        option = key.replace("_", "-")
        if isinstance(value, Mapping):
            values = _sweep_values(value, f"{name}.{key}", problems)
            if values is not None:
                swept[option] = values
        else:
            fixed[option] = value
    if len(problems) > before:
        return []  # a run with a malformed option expands to nothing (no follow-on errors)
    count = math.prod(len(values) for values in swept.values())
    if count > room:
        sizes = " x ".join(f"{len(v)} ({k})" for k, v in swept.items())
        problems.append(
            f"{name}: its sweeps make {sizes} = {count} entries, more than the "
            f"{MAX_ENTRIES} one batch may hold (with the runs before it); split the batch"
        )
        return []
    combinations = []
    for chosen in itertools.product(*swept.values()):
        options = {**fixed, **dict(zip(swept, chosen, strict=True))}
        combinations.append(_fill_templates(options, name, problems))
        if len(problems) > before:
            return []  # a template that cannot be filled fails every combination alike
    return combinations


def _sweep_values(sweep: Mapping[Any, Any], name: str, problems: list[str]) -> list[Any] | None:
    """The values a sweep mapping stands for, or None (and a problem) when malformed."""
    if len(sweep) != 1 or next(iter(sweep)) not in SWEEPS:
        problems.append(
            f"{name}: a sweep is a mapping with one key of {list(SWEEPS)}, found {dict(sweep)!r}"
        )
        return None
    ((how, given),) = sweep.items()
    if how == "range":
        if (
            not isinstance(given, list)
            or len(given) not in (2, 3)
            or any(isinstance(v, bool) or not isinstance(v, int) for v in given)
            or (len(given) == 3 and given[2] == 0)
        ):
            problems.append(
                f"{name}: range expects [start, stop] or [start, stop, step] integers "
                f"(step not 0), found {given!r}"
            )
            return None
        span = range(*given)
        try:
            size = len(span)
        except OverflowError:
            size = MAX_ENTRIES + 1
        if size > MAX_ENTRIES:
            problems.append(
                f"{name}: range {given!r} gives more than {MAX_ENTRIES} values; at most "
                f"{MAX_ENTRIES}"
            )
            return None
        values: list[Any] = list(span)
    elif how == "values":
        if not isinstance(given, list):
            problems.append(f"{name}: values expects a list, found {given!r}")
            return None
        values = list(given)
    else:
        if not isinstance(given, str) or not given:
            problems.append(f"{name}: glob expects a pattern string, found {given!r}")
            return None
        values = sorted(globbing.glob(given))
    if not values:
        problems.append(f"{name}: the sweep {dict(sweep)!r} gives no values")
        return None
    if len(values) > MAX_ENTRIES:
        problems.append(f"{name}: the sweep gives {len(values)} values, at most {MAX_ENTRIES}")
        return None
    return values


def _fill_templates(options: dict[str, Any], name: str, problems: list[str]) -> dict[str, Any]:
    """Strings naming other options in braces, filled in (``"out-{seed}"``)."""
    names = {key.replace("-", "_"): value for key, value in options.items()}
    filled = dict(options)
    for key, value in options.items():
        if not isinstance(value, str) or "{" not in value:
            continue
        try:
            fields = [f for _, f, _, _ in string.Formatter().parse(value) if f is not None]
            odd = [f for f in fields if not f.isidentifier()]
            if odd:
                problems.append(
                    f"{name}.{key}: the template {value!r} has the field {{{odd[0]}}}; fields "
                    f"are plain option names (as {{seed}}, or {{seed:03d}}): {sorted(names)}"
                )
                continue
            filled[key] = value.format_map(names)
        except (KeyError, ValueError, IndexError, AttributeError) as error:
            problems.append(
                f"{name}.{key}: the template {value!r} cannot be filled ({error}); it may name "
                f"the run's options {sorted(names)}"
            )
            continue
        if any(f.replace("-", "_") == key.replace("-", "_") for f in fields):
            problems.append(f"{name}.{key}: the template {value!r} names its own key")
    return filled
