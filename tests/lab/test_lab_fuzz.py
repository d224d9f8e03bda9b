"""Mutated lab exports, as a mislabelled or damaged record reaches a lab: each mutation
(and random pairs of them) gives one clear refusal naming the cause, or a trial with a note
saying what was done whose angles are the clean record's.

The mutations are those of issue 45: left and right markers swapped, plates swapped, every
vertical coordinate negated, a one-frame spike, a duplicated column, markers in millimetres.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from colloc.data.columns import JOINT_ANGLE_COLUMNS
from colloc.lab import LabFileError, LabSettings, lab_export_from_record, trial_from_lab
from colloc.lab.synthetic import write_lab_export
from colloc.models.gait2d_params import load_parameters

SUBJECT = (75.0, 1.8)


def _swap_sides(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    def renamed(column: str) -> str:
        if ".Pos" not in column:
            return column
        return {"R": "L", "L": "R"}.get(column[0], column[0]) + column[1:]

    return frame.rename(columns=renamed)


def _swap_plates(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    swap = {"FP1": "FP2", "FP2": "FP1"}

    def renamed(column: str) -> str:
        name, dot, channel = column.partition(".")
        return f"{swap[name]}.{channel}" if dot and name in swap else column

    return frame.rename(columns=renamed)


def _negate_vertical(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    out = frame.copy()
    columns = [c for c in out.columns if c.endswith(".PosY")]
    out[columns] = -out[columns]
    return out


def _spike(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    out = frame.copy()
    column = str(rng.choice([c for c in out.columns if ".Pos" in c]))
    row = int(rng.integers(50, len(out) - 50))
    out.loc[row, column] += float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.3, 1e3))
    return out


def _millimetres(frame: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    out = frame.copy()
    columns = [c for c in out.columns if ".Pos" in c]
    out[columns] = out[columns] * 1000.0
    return out


#: Mutation -> (function, the words of its refusal, or None for a trial with this note).
MUTATIONS = {
    "swap_sides": (_swap_sides, "swapped", None),
    "swap_plates": (_swap_plates, "swapped", None),
    "negate_vertical": (_negate_vertical, "not Y up", None),
    "spike": (_spike, None, "jump away and back"),
    "millimetres": (_millimetres, None, "markers in mm"),
    "duplicate": (None, "column names repeated", None),
}


@pytest.fixture(scope="module")
def clean(walk, tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    export = lab_export_from_record(walk, load_parameters(*SUBJECT), seed=8)
    path = write_lab_export(export, folder / "clean.tsv")
    trial = trial_from_lab(path, LabSettings(*SUBJECT, belt_speed=1.2)).trial
    return pd.read_csv(path, sep="\t"), trial


def _write(frame: pd.DataFrame, path, duplicate: bool) -> None:
    text = frame.to_csv(sep="\t", index=False, float_format="%.6f").splitlines()
    if duplicate:  # a column written twice under its own name (pandas would rename it)
        k = text[0].split("\t").index("RLEK.PosX")
        text = ["\t".join([*line.split("\t"), line.split("\t")[k]]) for line in text]
    path.write_text("\n".join(text) + "\n")


@pytest.mark.parametrize("seed", range(14))
def test_a_mutated_export_is_refused_by_its_cause_or_read_with_a_note(seed, clean, tmp_path):
    frame, reference = clean
    rng = np.random.default_rng(4500 + seed)
    names = list(MUTATIONS)
    # each mutation alone, then random pairs
    chosen = [names[seed]] if seed < len(names) else list(rng.choice(names, 2, replace=False))
    chosen.sort(key=names.index)  # a spike in metres, then the whole record in millimetres
    mutated = frame
    for name in chosen:
        function = MUTATIONS[name][0]
        if function is not None:
            mutated = function(mutated, rng)
    path = tmp_path / "mutated.tsv"
    _write(mutated, path, duplicate="duplicate" in chosen)
    refusals = [MUTATIONS[n][1] for n in chosen if MUTATIONS[n][1] is not None]
    mirrored = {"swap_sides", "swap_plates"} <= set(chosen)
    if mirrored:
        # markers and plates relabelled together: the left leg is called right throughout, a
        # consistent record a planar export cannot tell from the clean one (a 3-D record's
        # sides are checked against positions, tests/lab/test_lab_formats.py)
        refusals = [MUTATIONS[n][1] for n in chosen if not n.startswith("swap") and MUTATIONS[n][1]]
    try:
        result = trial_from_lab(path, LabSettings(*SUBJECT, belt_speed=1.2))
    except LabFileError as error:
        message = str(error)
        assert refusals, f"{chosen}: refused a record that should read: {message}"
        assert any(words in message for words in refusals), (chosen, message)
        return
    assert not refusals, f"{chosen}: a {refusals} record became a trial"
    for name in chosen:
        if MUTATIONS[name][2] is not None:
            assert any(MUTATIONS[name][2] in note for note in result.notes), (name, result.notes)
    # what was read is the clean record's walk (a spike filled; millimetres converted)
    angles = result.trial.signals[list(JOINT_ANGLE_COLUMNS)].to_numpy()
    columns = list(JOINT_ANGLE_COLUMNS)
    if mirrored:
        columns = [
            c.replace("right", "LEFT").replace("left", "right").replace("LEFT", "left")
            for c in columns
        ]
    truth = reference.signals[columns].to_numpy()
    assert np.degrees(np.abs(angles - truth)).max() < 2.0, chosen
