"""Figures of a gait controller identification: schedules with error bands, fits, validation."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure


def plot_schedule(
    estimates: Mapping[str, tuple[np.ndarray, np.ndarray | None]],
    joint_names: Sequence[str],
    title: str,
    *,
    band: float = 2.0,
) -> Figure:
    """One panel per joint: ``estimates`` (label -> values (P, 6), standard errors or None)
    against the schedule phase, with ``±band`` standard-error bands where given.

    Parameters
    ----------
    estimates : mapping
        Label -> (values, standard errors or None); values of shape (P, len(joint_names)).
    joint_names : sequence of str
    title : str
    band : float
        Width of the error band in standard errors.

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(11, 6), layout="constrained")
    axes = fig.subplots(2, (len(joint_names) + 1) // 2, sharex=True).ravel()
    for label, (values, se) in estimates.items():
        values = np.asarray(values, dtype=float)
        phase = np.arange(values.shape[0] + 1) / values.shape[0]
        for j, ax in enumerate(axes[: len(joint_names)]):
            closed = np.r_[values[:, j], values[0, j]]
            (line,) = ax.plot(phase, closed, marker=".", label=label)
            if se is not None:
                width = band * np.r_[se[:, j], se[0, j]]
                ax.fill_between(
                    phase, closed - width, closed + width, alpha=0.2, color=line.get_color()
                )
    for j, ax in enumerate(axes[: len(joint_names)]):
        ax.set_title(joint_names[j])
        ax.set_xlabel("phase")
    axes[0].legend(fontsize="small")
    fig.suptitle(title)
    return fig


def plot_angle_comparison(
    times: np.ndarray,
    measured: np.ndarray,
    model: np.ndarray,
    joint_names: Sequence[str],
    title: str,
    model_label: str,
) -> Figure:
    """Measured and modelled joint angles [deg] against time, one panel per joint.

    Parameters
    ----------
    times : ndarray, shape (N,)
    measured, model : ndarray, shape (N, k) and (M, k), M <= N
        Angles [rad]; ``model`` may end early (a simulation that fell).
    joint_names : sequence of str
    title, model_label : str

    Returns
    -------
    Figure
    """
    return plot_signal_comparison(
        times, np.degrees(measured), np.degrees(model), joint_names, title, model_label, "deg"
    )


def plot_signal_comparison(
    times: np.ndarray,
    measured: np.ndarray,
    model: np.ndarray,
    names: Sequence[str],
    title: str,
    model_label: str,
    unit: str,
) -> Figure:
    """Measured and modelled signals against time, one panel per signal.

    Parameters
    ----------
    times : ndarray, shape (N,)
    measured, model : ndarray, shape (N, k) and (M, k), M <= N
        In ``unit``; ``model`` may end early (a simulation that fell).
    names : sequence of str
    title, model_label, unit : str

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(11, 7), layout="constrained")
    axes = fig.subplots(len(names), 1, sharex=True)
    n = np.asarray(model).shape[0]
    for j, ax in enumerate(np.atleast_1d(axes)):
        ax.plot(times, measured[:, j], color="0.6", lw=1, label="measured")
        ax.plot(times[:n], model[:, j], lw=1, label=model_label)
        ax.set_ylabel(f"{names[j]}\n[{unit}]", fontsize="small")
    np.atleast_1d(axes)[0].legend(fontsize="small", loc="upper right")
    np.atleast_1d(axes)[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    return fig


def plot_torque_vaf(vaf: Mapping[str, Mapping[str, float]], title: str) -> Figure:
    """Held-out torque VAF per joint, one bar group per controller.

    Parameters
    ----------
    vaf : mapping
        Controller label -> joint -> VAF.
    title : str

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.subplots()
    labels = list(vaf)
    joints = list(next(iter(vaf.values())))
    width = 0.8 / max(len(labels), 1)
    for i, label in enumerate(labels):
        x = np.arange(len(joints)) + i * width
        ax.bar(x, [vaf[label][j] for j in joints], width, label=label)
    ax.set_xticks(np.arange(len(joints)) + 0.4 - width / 2, joints, rotation=20)
    ax.set_ylim(min(0.0, *(min(v.values()) for v in vaf.values())), 1.0)
    ax.axhline(0.95, color="k", lw=0.8, ls="--")
    ax.set_ylabel("VAF")
    ax.legend(fontsize="small")
    ax.set_title(title)
    return fig


def plot_bound_against_length(
    lengths: np.ndarray,
    bounds: np.ndarray,
    coefficient: float,
    target: float | None = None,
    needed: float | None = None,
) -> Figure:
    """The relative Cramér–Rao bound of ``K`` against the fitted length: the pilot's
    computed bounds, the law ``coefficient / sqrt(length)`` and, when given, the target and
    the length it needs.

    Parameters
    ----------
    lengths, bounds : ndarray
        Fitted seconds and the bounds computed there.
    coefficient : float
    target, needed : float, optional

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.subplots()
    top = max(float(np.max(lengths)), needed or 0.0) * 1.5
    grid = np.linspace(min(float(np.min(lengths)), 10.0), top, 200)
    ax.plot(grid, 100 * coefficient / np.sqrt(grid), label="c / sqrt(length)")
    ax.plot(lengths, 100 * np.asarray(bounds), "o", label="the pilot's design")
    if target is not None:
        ax.axhline(100 * target, color="0.5", lw=1, ls="--", label=f"target {100 * target:g} %")
    if needed is not None:
        ax.axvline(needed, color="0.5", lw=1, ls=":", label=f"{needed:.0f} s fitted")
    ax.set_xlabel("fitted record [s]")
    ax.set_ylabel("K bound [% of |K|]")
    ax.set_yscale("log")
    ax.legend(fontsize="small")
    fig.suptitle("Cramér–Rao bound of K against the record's length")
    return fig


def plot_mean_strides(
    phase: np.ndarray,
    record: np.ndarray,
    walks: Mapping[str, np.ndarray],
    joint_names: Sequence[str],
    title: str,
) -> Figure:
    """Joint angles [deg] over the gait cycle: the record's strides (mean and ±1 SD band)
    and each walk's mean stride, one panel per joint.

    Parameters
    ----------
    phase : ndarray, shape (n,)
        Gait-cycle phase in [0, 1].
    record : ndarray, shape (S, n, k)
        The record's strides [rad] (:func:`colloc.data.phase.phase_normalised`).
    walks : mapping
        Label -> mean stride [rad], shape (n, k).
    joint_names : sequence of str
    title : str

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(11, 6), layout="constrained")
    axes = fig.subplots(2, (len(joint_names) + 1) // 2, sharex=True).ravel()
    strides = np.degrees(np.asarray(record, dtype=float))
    for j, ax in enumerate(axes[: len(joint_names)]):
        if strides.shape[0]:
            mean, sd = strides[:, :, j].mean(axis=0), strides[:, :, j].std(axis=0)
            ax.fill_between(phase, mean - sd, mean + sd, color="0.8", label="record ±1 SD")
            ax.plot(phase, mean, color="k", lw=1.5, label="record")
        for label, values in walks.items():
            ax.plot(phase, np.degrees(values[:, j]), lw=1.2, label=label)
        ax.set_title(joint_names[j])
        ax.set_xlabel("gait cycle (right heel strike to the next)")
    axes[0].set_ylabel("angle [deg]")
    axes[0].legend(fontsize="small")
    fig.suptitle(title)
    return fig
