"""Bad input on the lab path refused by name before any work (issue 45): local workers out
of range or given with a scheduler, a scheduler address that answers garbage, blocks= for a
method without blocks, one marker prefix or plate for both sides."""

from __future__ import annotations

import os
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from colloc.batch.cluster import SchedulerError, dask_client
from colloc.cli import main
from colloc.cli.common import WORKERS_PER_CORE
from colloc.lab.markers import MarkerSet


def _identify(tmp_path: Path, *extra: str) -> list[str]:
    trial = tmp_path / "trial"
    trial.mkdir(exist_ok=True)
    return ["gait", "identify", str(trial), "--no-store", "--no-plots", *extra]


@pytest.mark.parametrize("workers", ["0", "-1", "1000000000"])
def test_local_workers_out_of_range_are_refused_by_the_parser(tmp_path, capsys, workers):
    with pytest.raises(SystemExit) as stop:
        main(_identify(tmp_path, "--window-strides", "2", "--workers", workers))
    assert stop.value.code == 2
    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    assert f"expected 1 to {most} local workers" in capsys.readouterr().err


def test_workers_and_a_scheduler_together_are_refused(tmp_path, capsys):
    argv = _identify(tmp_path, "--window-strides", "2", "--workers", "2")
    assert main([*argv, "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "--workers/--scheduler: expected one of them" in capsys.readouterr().err


def test_a_scheduler_answering_garbage_is_named_not_a_numpy_traceback():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    port = server.getsockname()[1]

    def answer_garbage() -> None:
        connection, _ = server.accept()
        connection.sendall(b"\xff" * 64 + b"HTTP/1.1 200 OK\r\n\r\nhello")
        time.sleep(0.5)
        connection.close()

    threading.Thread(target=answer_garbage, daemon=True).start()
    address = f"tcp://127.0.0.1:{port}"
    with pytest.raises(SchedulerError, match=f"could not use the Dask scheduler at '{address}'"):
        with dask_client(None, address):
            pass
    server.close()


@pytest.mark.parametrize(
    ("names", "message"),
    [
        ({"prefixes": {"right": "R", "left": "R"}}, "prefixes: expected a different one per side"),
        ({"plates": {"right": "FP1", "left": "FP1"}}, "both sides would read the same plate"),
        ({"prefixes": {"right": "", "left": "L"}}, "prefixes: expected a non-empty name"),
    ],
)
def test_one_prefix_or_plate_for_both_sides_is_refused(names, message):
    with pytest.raises(ValueError, match=message):
        MarkerSet(**names)


def test_the_command_names_the_flag_for_a_shared_plate(tmp_path, capsys):
    export = tmp_path / "export.tsv"
    export.write_text("time\n0\n")
    argv = ["gait", "trial-from-lab", str(export), "--mass", "70", "--height", "1.7"]
    argv += ["--belt-speed", "1.2", "--out", str(tmp_path / "t"), "--plates", "right=FP1,left=FP1"]
    assert main(argv) == 2
    assert (
        "--prefixes/--plates: plates: expected a different one per side" in capsys.readouterr().err
    )


def test_fill_gaps_names_every_bad_argument():
    from colloc.lab import fill_gaps

    good = np.arange(10) / 100.0
    cases = [
        (good[::-1], {"A": np.zeros((10, 2))}, "time: not strictly increasing at sample 1"),
        (np.r_[good[:5], np.nan, good[6:]], {"A": np.zeros((10, 2))}, "time: 1 NaN or infinite"),
        (good, {"A": np.zeros((10, 3))}, "marker A: expected shape \\(N, 2\\)"),
        (
            good,
            {"A": np.zeros((8, 2))},
            "marker A: 8 samples, expected one per time stamp \\(10\\)",
        ),
        (
            good,
            {"A": np.r_[np.zeros((3, 2)), [[np.inf, 0.0]], np.zeros((6, 2))]},
            "marker A: infinite at sample 3",
        ),
    ]
    for stamps, markers, message in cases:
        with pytest.raises(ValueError, match=message):
            fill_gaps(stamps, markers)


def test_a_lab_export_in_memory_is_checked_when_made():
    from colloc.lab import LabExport, LabFileError

    stamps = np.arange(10) / 100.0
    with pytest.raises(LabFileError, match="time: not strictly increasing"):
        LabExport(stamps[::-1], {}, {})
    with pytest.raises(LabFileError, match="marker RLEK: infinite at sample 2"):
        LabExport(stamps, {"RLEK": np.r_[np.zeros((2, 2)), [[np.inf, 1]], np.zeros((7, 2))]}, {})
    with pytest.raises(LabFileError, match="plate FP1: NaN or infinite at sample 0"):
        LabExport(stamps, {}, {"FP1": np.r_[[[np.nan, 0, 0]], np.zeros((9, 3))]})
    with pytest.raises(LabFileError, match=r"marker RLEK: expected shape \(10, 2\), found \(10,\)"):
        LabExport(stamps, {"RLEK": np.zeros(10)}, {})


def test_the_library_names_arguments_of_the_wrong_kind(tmp_path):
    from colloc.lab import LabSettings, process_lab, read_lab_export, trial_from_lab

    export = tmp_path / "x.tsv"
    export.write_text("time\tA.PosX\tA.PosY\n0\t0\t1\n0.01\t0\t1\n")
    with pytest.raises(TypeError, match="settings: expected LabSettings"):
        trial_from_lab(export, {"body_mass": 70})
    with pytest.raises(TypeError, match="settings: expected LabSettings.*found NoneType"):
        trial_from_lab(export, None)
    settings = LabSettings(70.0, 1.7, belt_speed=1.0)
    with pytest.raises(TypeError, match="markers_file: expected a file path, found int 3"):
        trial_from_lab(3, settings)
    with pytest.raises(TypeError, match="markers, forces: expected LabExport"):
        process_lab(None, settings)
    with pytest.raises(
        TypeError, match="names: expected a sequence of column names, found the string"
    ):
        read_lab_export(export, names="time,A.PosX")
    for tolerance in (float("nan"), -1):
        with pytest.raises(
            ValueError, match="sampling_tolerance: expected a fraction in \\[0, 1\\)"
        ):
            read_lab_export(export, sampling_tolerance=tolerance)
    assert (
        LabSettings(70.0, 1.7, belt_speed=1.0, max_gap=1e9)
        .problems()[0]
        .startswith("max_gap: expected seconds from 0 to 1")
    )


def test_a_repeated_column_and_stamps_in_milliseconds_are_named(tmp_path):
    from colloc.lab import LabFileError, read_lab_export

    repeated = tmp_path / "repeated.tsv"
    repeated.write_text("time\tRLEK.PosX\tRLEK.PosY\tRLEK.PosX\n0\t1\t2\t3\n0.01\t1\t2\t3\n")
    with pytest.raises(LabFileError, match="column names repeated: RLEK.PosX"):
        read_lab_export(repeated)
    milliseconds = tmp_path / "ms.tsv"
    milliseconds.write_text(
        "time\tA.PosX\tA.PosY\n" + "".join(f"{10 * k}\t0\t1\n" for k in range(20))
    )
    with pytest.raises(LabFileError, match="time stamps in milliseconds"):
        read_lab_export(milliseconds)
