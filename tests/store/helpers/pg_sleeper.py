"""Not collected by the suite: run alone by ``test_postgres_fixture`` to be interrupted mid-test."""

import os
import time
from pathlib import Path


def test_hold_the_server(postgres_server):
    Path(os.environ["COLLOC_PG_READY"]).write_text(str(Path(postgres_server.pgdata).parent))
    time.sleep(120)
