"""The report of a batch: a summary table (CSV and Markdown) and figures.

Two tables, each written when the batch has runs of its kind:

- **pendulum**, one row per gain over the batch's pendulum runs grouped by everything but
  the seed (a noise-realisation study): the known value, the mean estimate and its bias, the
  spread (standard deviation) of the estimates, the mean reported standard error, their
  ratio (near 1 when the error bars are honest) and the fractions within 2 and 3 reported
  standard errors of the truth; and a figure of spread against mean standard error.
- **gait identifications**, one row per run: the trial, the relative errors of K and T*,
  the share of entries within 3 standard errors, the held-out torque VAF per joint and
  whether the identified controller walks; and a figure of the gain errors and VAF per trial.

Every entry also appears in ``entries.csv``: its kind, status, run id, output, error and
time.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from colloc.store.runs import RunStore

#: Columns of the per-gain table of a pendulum study.
PENDULUM_COLUMNS = (
    "group",
    "gain",
    "runs",
    "known",
    "mean",
    "bias",
    "spread",
    "mean_se",
    "spread_over_se",
    "within_2se",
    "within_3se",
)


def pendulum_table(store: RunStore, run_ids: Sequence[str]) -> pd.DataFrame:
    """Per gain, over pendulum runs with equal settings but the seed: bias, spread, SE.

    Parameters
    ----------
    store : RunStore
    run_ids : sequence of str
        Runs to summarise; other kinds are ignored.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`PENDULUM_COLUMNS`; ``group`` numbers the distinct settings.
    """
    return _pendulum_frame(_records(store, run_ids))


def _records(store: RunStore, run_ids: Sequence[str]) -> list[Any]:
    """The runs' records without their arrays (the tables need parameters and statistics)."""
    return [store.get(run_id, arrays=False) for run_id in run_ids]


def _pendulum_frame(records: Sequence[Any]) -> pd.DataFrame:
    groups: dict[str, list[Any]] = {}
    for record in records:
        if record.kind != "pendulum":
            continue
        settings = {k: v for k, v in record.settings.items() if k != "seed"}
        groups.setdefault(json.dumps(settings, sort_keys=True, default=str), []).append(record)
    rows = []
    for group, records in enumerate(groups.values()):
        names = [p.name for p in records[0].parameters]
        for i, name in enumerate(names):
            known = np.array([r.parameters[i].known for r in records], dtype=float)
            est = np.array([r.parameters[i].identified for r in records], dtype=float)
            se = np.array(
                [
                    np.nan if r.parameters[i].std_error is None else r.parameters[i].std_error
                    for r in records
                ],
                dtype=float,
            )
            spread = float(np.std(est, ddof=1)) if len(est) > 1 else float("nan")
            mean_se = float(np.nanmean(se)) if np.isfinite(se).any() else float("nan")
            z = np.abs(est - known) / se
            rows.append(
                [
                    group,
                    name,
                    len(records),
                    float(np.mean(known)),
                    float(np.mean(est)),
                    float(np.mean(est - known)),
                    spread,
                    mean_se,
                    spread / mean_se if mean_se > 0 else float("nan"),
                    float(np.mean(z <= 2.0)) if np.isfinite(z).all() else float("nan"),
                    float(np.mean(z <= 3.0)) if np.isfinite(z).all() else float("nan"),
                ]
            )
    return pd.DataFrame(rows, columns=pd.Index(PENDULUM_COLUMNS))


def gait_table(store: RunStore, run_ids: Sequence[str]) -> pd.DataFrame:
    """One row per gait identification: gain errors, held-out torque VAF, walks.

    Parameters
    ----------
    store : RunStore
    run_ids : sequence of str
        Runs to summarise; other kinds are ignored.

    Returns
    -------
    pandas.DataFrame
        ``run_id, trial, K_relative_error, Tstar_relative_error, fraction_within_3se,
        walks``, then ``vaf_<joint>`` (collocation controller) per joint.
    """
    return _gait_frame(_records(store, run_ids))


def _gait_frame(records: Sequence[Any]) -> pd.DataFrame:
    rows = []
    for record in records:
        if record.kind != "gait-identify":
            continue
        stats = record.statistics
        validation = stats.get("validation") or {}
        vaf = (validation.get("torque_vaf") or {}).get("collocation") or {}
        row = {
            "run_id": record.run_id,
            "trial": record.settings.get("trial"),
            "K_relative_error": stats.get("K_relative_error"),
            "Tstar_relative_error": stats.get("Tstar_relative_error"),
            "fraction_within_3se": stats.get("fraction_within_3se"),
            "walks": validation.get("walks"),
        }
        row.update({f"vaf_{joint}": value for joint, value in vaf.items()})
        rows.append(row)
    return pd.DataFrame(rows)


def write_batch_report(
    store: RunStore, batch_id: str, directory: str | os.PathLike[str]
) -> list[Path]:
    """Write a batch's tables (CSV and Markdown) and figures into ``directory``.

    Parameters
    ----------
    store : RunStore
    batch_id : str
        Full id or unique prefix.
    directory : path-like
        Created if missing.

    Returns
    -------
    list of Path
        The files written: ``entries.csv``/``.md``, and ``pendulum-gains``/``gait-runs``
        tables and figures where the batch has such runs.

    Raises
    ------
    colloc.store.RunNotFoundError
        If no batch, or more than one, matches ``batch_id``.
    """
    batch = store.batches.get(batch_id)
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    entries = batch["entries"].drop(columns=["settings"])
    written = _write_table(entries, out, "entries")
    records = _records(store, [r for r in entries["run_id"] if isinstance(r, str)])
    pendulum = _pendulum_frame(records)
    if not pendulum.empty:
        written += _write_table(pendulum, out, "pendulum-gains")
        written += _pendulum_figure(pendulum, out)
    gait = _gait_frame(records)
    if not gait.empty:
        written += _write_table(gait, out, "gait-runs")
        written += _gait_figure(gait, out)
    return written


def _write_table(frame: pd.DataFrame, out: Path, stem: str) -> list[Path]:
    csv, markdown = out / f"{stem}.csv", out / f"{stem}.md"
    frame.to_csv(csv, index=False)
    markdown.write_text(_markdown(frame), encoding="utf-8")
    return [csv, markdown]


def _markdown(frame: pd.DataFrame) -> str:
    """A GitHub-style table (pandas' to_markdown needs tabulate, which we do not ship)."""

    def cell(value: Any) -> str:
        if isinstance(value, float):
            return "" if np.isnan(value) else f"{value:.4g}"
        return "" if value is None else str(value).replace("|", "\\|").replace("\n", " ")

    header = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(False)]
    return "\n".join([header, rule, *body]) + "\n"


def _pendulum_figure(table: pd.DataFrame, out: Path) -> list[Path]:
    from colloc.plot.common import new_figure, save_figure

    fig = new_figure(1, width=7.0, height_per_axis=3.2)
    ax = fig.axes[0]
    x = np.arange(len(table))
    ax.bar(x - 0.2, table["spread"], width=0.4, label="spread of the estimates")
    ax.bar(x + 0.2, table["mean_se"], width=0.4, label="mean reported standard error")
    labels = [
        f"{g}:{n}" if table["group"].nunique() > 1 else n
        for g, n in zip(table["group"], table["gain"], strict=True)
    ]
    ax.set_xticks(x, labels, rotation=45, ha="right")
    ax.set_ylabel("gain units")
    ax.set_title(f"{int(table['runs'].max())} realisations: spread vs reported standard error")
    ax.legend()
    return save_figure(fig, out, "pendulum-spread-vs-se")


def _gait_figure(table: pd.DataFrame, out: Path) -> list[Path]:
    from colloc.plot.common import new_figure, save_figure

    fig = new_figure(2, width=7.0, height_per_axis=2.6)
    # the trial folder's last two parts: simulated trials all end in ".../trial"
    labels = ["/".join(Path(str(t)).parts[-2:]) for t in table["trial"]]
    x = np.arange(len(table))
    top, bottom = fig.axes
    for column in ("K_relative_error", "Tstar_relative_error"):
        top.plot(x, pd.to_numeric(table[column], errors="coerce"), "o-", label=column)
    top.set_ylabel("relative error")
    top.legend()
    for column in [c for c in table.columns if c.startswith("vaf_")]:
        bottom.plot(x, pd.to_numeric(table[column], errors="coerce"), "o-", label=column[4:])
    bottom.set_ylabel("held-out torque VAF")
    bottom.set_xticks(x, labels, rotation=30, ha="right")
    bottom.legend(fontsize="small", ncol=3)
    return save_figure(fig, out, "gait-runs")
