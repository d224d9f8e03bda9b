"""Run ids: stable hashes of settings, data and versions."""

from __future__ import annotations

import hashlib
import importlib.metadata
import platform

import numpy as np
import pytest

from colloc.store import RecordError, canonical_json, digest_arrays, package_versions, run_id_for

SETTINGS = {"num_links": 1, "scheme": "backward_euler", "h": 0.01, "noise": {"seed": 7}}
VERSIONS = {"python": "3.11.7", "numpy": "2.4.6", "casadi": "3.8.2"}


def test_run_id_is_sha256_of_the_canonical_json():
    # Written out by hand: sorted keys, no spaces, shortest float form.
    text = (
        '{"data":"d1","settings":{"h":0.01,"noise":{"seed":7},"num_links":1,'
        '"scheme":"backward_euler"},"versions":{"casadi":"3.8.2","numpy":"2.4.6",'
        '"python":"3.11.7"}}'
    )
    assert run_id_for(SETTINGS, "d1", VERSIONS) == hashlib.sha256(text.encode()).hexdigest()


def test_same_inputs_give_the_same_id():
    reordered = {
        "noise": {"seed": np.int64(7)},
        "h": np.float64(0.01),
        "scheme": "backward_euler",
        "num_links": 1,
    }
    assert run_id_for(SETTINGS, "d1", VERSIONS) == run_id_for(reordered, "d1", dict(VERSIONS))


@pytest.mark.parametrize(
    ("settings", "digest", "versions"),
    [
        ({**SETTINGS, "h": 0.005}, "d1", VERSIONS),
        ({**SETTINGS, "noise": {"seed": 8}}, "d1", VERSIONS),
        ({**SETTINGS, "extra": None}, "d1", VERSIONS),
        (SETTINGS, "d2", VERSIONS),
        (SETTINGS, "d1", {**VERSIONS, "numpy": "2.4.7"}),
    ],
)
def test_any_change_gives_another_id(settings, digest, versions):
    assert run_id_for(settings, digest, versions) != run_id_for(SETTINGS, "d1", VERSIONS)


def test_run_id_inputs_are_checked_all_at_once():
    with pytest.raises(RecordError, match="3 problem") as caught:
        run_id_for({"h": float("nan"), "f": print}, b"bytes", VERSIONS)
    message = str(caught.value)
    assert "data_digest: expected a str, found bytes" in message
    assert "settings['h']: expected a finite number, found nan" in message
    assert "settings['f']: expected JSON data" in message


def test_canonical_json_converts_numpy():
    assert canonical_json({"b": np.arange(3), "a": (np.float32(0.5), np.bool_(True))}) == (
        '{"a":[0.5,true],"b":[0,1,2]}'
    )
    with pytest.raises(RecordError, match=r"settings\[0\]: expected JSON data"):
        canonical_json([{1, 2}], "settings")


def test_digest_arrays_ignores_memory_layout_but_not_values():
    values = np.arange(12.0).reshape(3, 4)
    reference = digest_arrays({"q": values, "t": np.arange(3)})
    same = {"t": np.arange(3), "q": np.asfortranarray(values).astype(">f8")}
    assert digest_arrays(same) == reference
    changed = values.copy()
    changed[2, 3] = np.nextafter(changed[2, 3], 100.0)
    assert digest_arrays({"q": changed, "t": np.arange(3)}) != reference
    assert digest_arrays({"q": values.reshape(4, 3), "t": np.arange(3)}) != reference
    assert digest_arrays({"r": values, "t": np.arange(3)}) != reference
    assert digest_arrays({"q": values.astype(np.float32), "t": np.arange(3)}) != reference


def test_digest_arrays_refuses_objects():
    with pytest.raises(RecordError, match=r"arrays\['x'\]: arrays of Python objects"):
        digest_arrays({"x": np.array([None, 1])})


def test_package_versions_match_importlib_metadata():
    versions = package_versions()
    assert set(versions) == {"python", "colloc", "numpy", "scipy", "sympy", "casadi", "cyipopt"}
    assert versions["python"] == platform.python_version()
    assert versions["numpy"] == np.__version__
    assert versions["scipy"] == importlib.metadata.version("scipy")
