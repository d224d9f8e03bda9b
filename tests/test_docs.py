"""The docs site: built in strict mode, every public name in the reference with its docstring,
every example run.

The examples are also the gallery's tests of a plain parameter estimation (a cubic spring,
against SciPy's ``solve_ivp``) and of an unknown input trajectory. The build is
``mkdocs build --strict`` (``./dev docs``) into a temporary folder: a broken
link, a reference that does not resolve or any other warning fails it. The examples in
``docs/examples`` run at small sizes and must write the figures the pages show.
"""

from __future__ import annotations

import html
import importlib
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _hooks():
    spec = importlib.util.spec_from_file_location("colloc_docs_hooks", DOCS / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def public_entries() -> list[tuple[str, str, str]]:
    """(page package, public name, the path the reference documents it under)."""
    hooks = _hooks()
    entries = []
    for package_name in ("colloc", *hooks.PAGES):
        package = importlib.import_module(package_name)
        for name in package.__all__:
            obj = getattr(package, name)
            if name.startswith("__") or isinstance(obj, type(sys)):
                continue
            home = hooks._documented_elsewhere(package_name, name, obj)
            page = home or package_name
            target = hooks._defining_module(importlib.import_module(page), name, obj)
            entries.append((page, name, f"{target}.{name}"))
    return entries


def _letters(text: str) -> str:
    """Only the letters and digits: markup and spacing differ between a docstring and HTML."""
    return re.sub(r"[^A-Za-z0-9]", "", text)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [str(Path(sys.executable).with_name("mkdocs")), "build", "--strict", "-d", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"},
        check=False,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out


def test_every_public_name_has_a_docstring():
    import griffe

    loaded = griffe.load("colloc", search_paths=[str(ROOT / "src")], resolve_aliases=True)
    missing = []
    for _, _, path in public_entries():
        obj = loaded[path.removeprefix("colloc.")]
        if obj.is_alias:
            obj = obj.final_target
        if obj.docstring is None or not obj.docstring.value.strip():
            missing.append(path)
    assert missing == []


def test_the_site_builds_strictly_with_every_public_name_and_its_docstring(site):
    import griffe

    loaded = griffe.load("colloc", search_paths=[str(ROOT / "src")], resolve_aliases=True)
    pages = {}
    absent = []
    for page, _, path in public_entries():
        stem = "colloc" if page == "colloc" else page.removeprefix("colloc.")
        if stem not in pages:
            pages[stem] = html.unescape(
                re.sub(r"<[^>]+>", " ", (site / "api" / stem / "index.html").read_text())
            )
        text = pages[stem]
        obj = loaded[path.removeprefix("colloc.")]
        obj = obj.final_target if obj.is_alias else obj
        first = obj.docstring.value.strip().splitlines()[0]
        words = _letters(re.sub(r":\w+:", "", first))[:24]
        if path.rsplit(".", 1)[1] not in text or words not in _letters(text):
            absent.append((stem, path, first))
    assert absent == [], absent


def test_the_command_line_page_is_the_parsers_help(site):
    from colloc.cli import build_parser

    text = html.unescape((site / "cli" / "index.html").read_text())
    assert build_parser().format_help().splitlines()[0].replace("usage: ", "") in text
    for command in (
        "colloc pendulum",
        "colloc gait identify",
        "colloc batch run",
        "colloc runs export",
    ):
        assert f"<code>{command}</code>" in text


def test_every_page_in_the_docs_folder_is_in_the_navigation():
    import yaml

    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text().replace("!!python", "#"))
    listed = set()

    def walk(items):
        for item in items:
            for value in item.values():
                walk(value) if isinstance(value, list) else listed.add(value)

    walk(config["nav"])
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")}
    assert pages == listed


def test_the_own_model_example_recovers_its_parameters(tmp_path):
    sys.path.insert(0, str(DOCS / "examples"))
    try:
        import own_model
    finally:
        sys.path.pop(0)
    table = own_model.main(tmp_path, duration=10.0)
    for name, (true, estimate, error) in table.items():
        assert abs(estimate - true) < 3 * error, name
        assert error < 0.05 * true  # the record determines each of them
    assert (tmp_path / "own-model.png").stat().st_size > 10_000


def test_the_trials_example_recovers_shared_and_own_parameters():
    sys.path.insert(0, str(DOCS / "examples"))
    try:
        import shared_trials as trials
    finally:
        sys.path.pop(0)
    table = trials.main()
    assert set(table) == {"c", "k", "b0", "b1", "b2", "b3"}
    for name, (true, estimate, error) in table.items():
        assert abs(estimate - true) < 3 * error, name
        assert 0 < error < 0.01 * max(abs(true), 1.0), name
    # the page shows what the example prints
    page = (DOCS / "own-model.md").read_text()
    for name, (_, estimate, error) in table.items():
        assert f"{name:>3} = {estimate:9.5f} +/- {error:.5f}" in page, name


@pytest.mark.slow  # 51 s: the docs example run whole; benchmarks/slow_tests.py runs it
def test_the_unknown_input_example_recovers_the_parameters_and_the_force(tmp_path):
    sys.path.insert(0, str(DOCS / "examples"))
    try:
        import unknown_input
    finally:
        sys.path.pop(0)
    out = unknown_input.main(tmp_path, duration=10.0)
    estimate, applied = out.pop("force")
    for name, (true, found, error) in out.items():
        assert abs(found - true) < 3 * error, name
        assert error < 0.1 * true
    rms = np.sqrt(np.mean((estimate - applied) ** 2))
    assert rms < np.sqrt(0.2) * np.sqrt(np.mean(applied**2))  # >= 80 % of its variance
    assert (tmp_path / "unknown-input.png").stat().st_size > 10_000


GAIT_FIGURES = ("gait-schedule-tstar.png", "gait-schedule-stiffness.png")
#: A measured run's figures (the 8-minute trial's 360 s fit, docs/gait.md), committed as
#: measured: no test can afford the run; the pages' figures must still exist.
MEASURED_FIGURES = (
    "gait-8min-stiffness.png",
    "gait-8min-vaf.png",
    "gait-8min-walk.png",
    # colloc gait identify's validation_walk_phase on a 60 s simulated walk (the command is in
    # docs/gait-guide.md; 8.5 minutes, too long for the tests)
    "gait-walk-phase.png",
    # docs/examples/opensim_walk.py, from OpenSim's example walk, which colloc may not ship
    "opensim-walk.png",
    "opensim-smooth.png",
)
LAB_FIGURES = ("lab-clip-kinematics.png", "lab-clip-moments.png")


def test_the_lab_example_draws_the_real_clips_figures(tmp_path):
    sys.path.insert(0, str(DOCS / "examples"))
    try:
        import lab_clip
    finally:
        sys.path.pop(0)
    clip = ROOT / "tests" / "data" / "records" / "gatk-leg2d-sagittal-gait-3s"
    written = lab_clip.main(clip, tmp_path)
    assert sorted(p.name for p in written) == sorted(LAB_FIGURES)
    assert all(p.stat().st_size > 10_000 for p in written)


def test_the_gait_example_draws_a_trials_schedule(tmp_path):
    sys.path.insert(0, str(DOCS / "examples"))
    try:
        import gait_schedule
    finally:
        sys.path.pop(0)
    trial = ROOT / "tests" / "identify" / "data" / "gait_trial_p20"
    written = gait_schedule.main(trial, tmp_path)
    assert sorted(p.name for p in written) == sorted(GAIT_FIGURES)
    assert all(p.stat().st_size > 10_000 for p in written)


def test_the_pendulum_example_draws_the_figures_the_pages_show(tmp_path, capsys):
    sys.path.insert(0, str(DOCS / "examples"))
    try:
        import pendulum_study
    finally:
        sys.path.pop(0)
    written = {p.name for p in pendulum_study.main(tmp_path, duration=10.0)}
    shown = set()
    for page in DOCS.glob("*.md"):
        shown |= set(re.findall(r"\(figures/([\w.-]+\.png)\)", page.read_text()))
    assert (
        shown
        - {"own-model.png", "unknown-input.png", *GAIT_FIGURES, *MEASURED_FIGURES, *LAB_FIGURES}
        <= written
    )
    assert all((DOCS / "figures" / name).is_file() for name in shown)  # committed for the site
    assert "k_0_0: known" in capsys.readouterr().out
