"""Every Python example in README.md runs as written.

The examples name the user's objects (``kane``, ``torques``, measured arrays, guesses); this
test provides them from the seed's 1-link cart pendulum, simulated by the pendulum study, and
runs each ```` ```python ```` block of the README in turn in one namespace. The library
example's solve is then checked against the study's own identification of the same data.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import sympy

import colloc
from colloc.identify import PendulumSettings, run_pendulum
from colloc.models import pendulum_cart

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_every_python_example_in_the_readme_runs():
    blocks = python_blocks(README.read_text())
    assert len(blocks) >= 2  # the library example and the noise-model one
    run = run_pendulum(
        PendulumSettings(num_links=1, duration=10, sensor_noise=True, initial_guess="close")
    )
    plant = pendulum_cart.derive(1)
    q0, q1 = plant.coordinates
    measured = run.measurements
    rates = np.gradient(measured, run.times, axis=0)
    namespace = {
        "sympy": sympy,
        "kane": plant.kane,
        "torques": list(plant.torques),
        "F": plant.force,
        "t": run.times,
        "force": run.force,
        "constants": plant.default_constants(),
        "q0": q0,
        "q1": q1,
        "q0_measured": measured[:, 0],
        "q1_measured": measured[:, 1],
        # arrays, as the example documents: (N, n) states in model order, the gains
        "state_guess": np.hstack([measured, rates]),
        "gain_guess": run.initial_gains,
        "sigma": np.radians(0.25),
        "sigma_w": 1.0,
        "force_measured": run.force,
        "sigma_F": 0.5,
    }
    first = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"README.md python block {i}", "exec"), namespace)
        if i == 0:
            first = dict(namespace)
    solution = first["solution"]
    assert isinstance(solution, colloc.Solution) and solution.success
    gains = [solution.parameters[k] for k in run.gain_symbols]
    np.testing.assert_allclose(gains, run.identified_gains, rtol=1e-5)
    assert isinstance(namespace["problem"], colloc.Problem)
    assert namespace["problem"].process_noise


def test_the_readme_batch_file_is_valid_as_written(tmp_path, monkeypatch):
    import yaml

    from colloc.batch import expand_batch
    from colloc.cli.batch import KINDS, build_tasks

    (block,) = re.findall(r"```yaml\n(.*?)```", README.read_text(), flags=re.S)
    monkeypatch.chdir(tmp_path)  # its relative paths land here
    spec = expand_batch(yaml.safe_load(block), tuple(KINDS))
    tasks, problems = build_tasks(spec.entries)
    assert problems == []
    assert [t.kind for t in tasks].count("pendulum") == 100
    assert sorted(t.settings.seed for t in tasks if t.kind == "pendulum") == list(range(100))
    simulations = {t.position: t for t in tasks if t.kind == "gait-simulate"}
    for fit in (t for t in tasks if t.kind == "gait-identify"):  # each waits for its trial
        (before,) = fit.after
        assert (
            simulations[before].settings.out / "trial"
        ).resolve() == fit.settings.trial.resolve()
    assert spec.db == "sqlite:///noise-study.db"
