"""Bad input on the lab path refused by name before any work (issue 45): local workers out
of range or given with a scheduler, a scheduler address that answers garbage, blocks= for a
method without blocks, one marker prefix or plate for both sides."""

from __future__ import annotations

import os
import socket
import threading
import time
from pathlib import Path

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
