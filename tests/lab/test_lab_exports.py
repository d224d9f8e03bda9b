"""Reading lab exports: the real GaitAnalysisToolKit clips, header-less files, every problem named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from colloc.lab import LabFileError, fill_gaps, read_lab_export

RECORDS = Path(__file__).resolve().parents[1] / "data" / "records" / "gatk-leg2d-sagittal-gait-3s"
CLIP = RECORDS / "rawdata.txt"
CLIP2 = RECORDS / "leg2d-unit-test-branch" / "input.tsv"


def clip_names() -> list[str]:
    return CLIP.read_text().splitlines()[0].lstrip("%").split()


def test_the_real_clip_reads_with_its_comment_header_and_nan_gaps():
    export = read_lab_export(CLIP)
    assert export.time.size == 301 and export.sample_rate == pytest.approx(100.0)
    assert sorted(export.markers) == ["RGTRO", "RHEE", "RLEK", "RLM", "RMT5", "RSHO"]
    assert list(export.plates) == ["FP2"] and export.columns == {}
    # the 11 NaN rows of the file (SOURCE.md), counted per marker
    assert export.missing() == {"RSHO": 1, "RGTRO": 2, "RLEK": 3, "RLM": 5}
    # a value read as written: row 7.21 s, FP2.ForY
    assert export.plates["FP2"][21, 1] == pytest.approx(48.41805)
    assert export.markers["RLM"][0] == pytest.approx([0.67025, 0.14642])


def test_a_headerless_clip_needs_names_and_its_exact_zeros_are_missing():
    with pytest.raises(LabFileError, match="first line holds numbers"):
        read_lab_export(CLIP2)
    export = read_lab_export(CLIP2, names=clip_names())
    assert export.missing() == {"RGTRO": 35}  # rows with RGTRO at exactly 0, 0
    kept = read_lab_export(CLIP2, names=clip_names(), zeros_are_missing=False)
    assert kept.missing() == {}
    with pytest.raises(LabFileError, match="3 given, but the file has 16 columns"):
        read_lab_export(CLIP2, names=["a", "b", "c"])


def test_every_problem_of_a_bad_export_is_named_at_once(tmp_path):
    bad = tmp_path / "bad.tsv"
    bad.write_text(
        "Frame\tRHEE.PosX\tRMT5.PosX\tRMT5.PosY\tFP1.ForX\tFP1.ForY\n"
        "1\t0.1\t0.2\t0.0\t1\t2\n"
        "2\tx\t0.2\t0.0\t1\t2\n"
    )
    with pytest.raises(LabFileError) as info:
        read_lab_export(bad)
    problems = info.value.problems
    assert any("RHEE.PosX: 1 entries are not numbers" in p and "'x'" in p for p in problems)
    assert any("no time stamp column" in p for p in problems)
    assert any("marker RHEE: no column RHEE.PosY" in p for p in problems)
    assert any("plate FP1: no column FP1.MomZ" in p for p in problems)
    assert len(problems) == 4


def test_time_must_increase_evenly_and_plates_have_no_gaps(tmp_path):
    rows = ["TimeStamp,M.PosX,M.PosY,FP1.ForX,FP1.ForY,FP1.MomZ"]
    rows += [f"{t:.2f},0.1,0.2,1,2,3" for t in (0.0, 0.01, 0.02, 0.05, 0.06)]
    uneven = tmp_path / "uneven.csv"
    uneven.write_text("\n".join(rows) + "\n")
    with pytest.raises(LabFileError, match="uneven sampling.*row 4"):
        read_lab_export(uneven)
    rows = ["TimeStamp,M.PosX,M.PosY,FP1.ForX,FP1.ForY,FP1.MomZ"]
    rows += [f"{0.01 * k:.2f},0.1,0.2,1,{'NaN' if k == 2 else 2},3" for k in range(5)]
    gap = tmp_path / "gap.csv"
    gap.write_text("\n".join(rows) + "\n")
    with pytest.raises(LabFileError, match=r"plate FP1: 1 NaN .*row 3"):
        read_lab_export(gap)
    with pytest.raises(LabFileError, match="file not found"):
        read_lab_export(tmp_path / "none.csv")


def test_gaps_are_filled_by_a_spline_to_the_signal_and_long_or_edge_gaps_are_reported():
    time = np.arange(200) / 100.0
    true = np.column_stack([np.sin(2 * np.pi * time), np.cos(2 * np.pi * 0.7 * time)])
    marker = true.copy()
    marker[50:60] = np.nan  # 0.1 s interior gap
    marker[:3] = np.nan  # unseen at the start
    filled, gaps, span = fill_gaps(time, {"M": marker}, max_gap=0.15)
    # within the interpolating cubic spline's error bound 5/384 h^4 max|f| (Hall and Meyer) for the
    # gap's knot interval h = 0.11 s and f = sin(2 pi t): 3e-3 (measured 2e-4)
    bound = 5.0 / 384.0 * 0.11**4 * (2 * np.pi) ** 4
    assert np.abs(filled["M"][50:60] - true[50:60]).max() < bound
    assert span == slice(3, 200)
    assert [(g.samples, g.filled) for g in gaps] == [(3, False), (10, True)]
    with pytest.raises(ValueError, match=r"marker M: missing from 0.5 to 0.59 s \(10 samples"):
        fill_gaps(time, {"M": marker}, max_gap=0.05)
    with pytest.raises(ValueError, match="max_gap"):
        fill_gaps(time, {"M": marker}, max_gap=-1.0)
