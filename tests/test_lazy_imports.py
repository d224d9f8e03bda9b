"""Start-up stays cheap: packages export their names lazily, heavy libraries load on use."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys

import pytest

LAZY_PACKAGES = ("colloc", "colloc.identify", "colloc.lab", "colloc.plot", "colloc.store")
HEAVY = ("pandas", "matplotlib", "sqlalchemy", "colloc.plot.pendulum", "colloc.store.runs")


def loaded_after(code: str) -> list[str]:
    """The heavy modules a fresh interpreter holds after running ``code``."""
    probe = (
        f"import json, sys\n{code}\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_import_colloc_loads_no_heavy_library():
    assert loaded_after("import colloc") == []


def test_help_loads_no_heavy_library():
    code = "from colloc.cli import build_parser\nbuild_parser().format_help()"
    assert loaded_after(code) == []


def test_a_pendulum_run_without_store_or_figures_loads_none_of_them(tmp_path):
    code = (
        "from colloc.cli import main\n"
        "code = main(['pendulum', '-n', '1', '-d', '2', '-s', '50', '--no-store'])\n"
        "assert code == 0, code"
    )
    assert loaded_after(code) == []


def test_the_probe_sees_a_heavy_import():
    # the probe itself can fail: an explicit import shows up
    assert loaded_after("import colloc.store.runs") == ["pandas", "sqlalchemy", "colloc.store.runs"]


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_every_exported_name_resolves(package):
    module = importlib.import_module(package)
    for name in module.__all__:
        assert getattr(module, name) is not None, name
        assert name in dir(module)


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_an_unknown_name_raises_attribute_error(package):
    module = importlib.import_module(package)
    with pytest.raises(AttributeError, match="no_such_name"):
        module.no_such_name  # noqa: B018


def test_a_lazy_name_is_the_defining_module_object():
    import colloc
    from colloc.nlp.problem import Problem

    assert colloc.Problem is Problem
    assert colloc.transcription is importlib.import_module("colloc.transcription")


def test_help_needs_neither_sympy_nor_casadi():
    code = (
        "import sys\nfrom colloc.cli import build_parser\nbuild_parser().format_help()\n"
        "assert 'sympy' not in sys.modules and 'casadi' not in sys.modules, 'heavy'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_scheme_names_of_the_settings_are_the_workflow_schemes():
    from colloc.identify.pendulum.settings import SCHEME_NAMES
    from colloc.identify.pendulum.workflow import SCHEMES

    assert tuple(SCHEMES) == SCHEME_NAMES
    names = [cls().name.lower() for cls in SCHEMES.values()]
    assert names == [n.replace("-", "") for n in SCHEME_NAMES]
