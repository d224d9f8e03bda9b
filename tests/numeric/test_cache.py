"""The on-disk cache of built functions: hits, misses, opting out, corrupt entries."""

from __future__ import annotations

import json
import logging

import numpy as np
import pytest
import sympy as sm
from sympy.physics.mechanics import dynamicsymbols

from colloc import Model, Problem, Tracking
from colloc.numeric.cache import BuildCache, cache_key, default_cache_dir
from colloc.transcription import HermiteSimpson, Midpoint

t = dynamicsymbols._t
theta, omega = dynamicsymbols("theta omega")
m, g, ell, c = sm.symbols("m g l c")
TIMES = np.linspace(0.0, 1.0, 11)


def pendulum():
    return Model.from_equations(
        [
            theta.diff(t) - omega,
            m * ell**2 * omega.diff(t) + c * omega + m * g * ell * sm.sin(theta),
        ],
        [theta, omega],
        outputs=[theta],
    )


def build(cache, scheme=None, measured=None, known=None):
    return Problem(
        pendulum(),
        TIMES,
        scheme=scheme or Midpoint(),
        known_parameters=known or {m: 1.0, g: 9.81, ell: 0.5},
        objective=Tracking({theta: np.cos(TIMES) if measured is None else measured}),
        instance_constraints=[theta.func(0.0) - 1.0],
        cache=cache,
    )


def sample_point(problem, seed=0):
    return np.random.default_rng(seed).normal(size=problem.layout.num_variables)


def evaluations(problem, z):
    nlp = problem.nlp
    lam = np.linspace(-1.0, 1.0, nlp.m)
    return [
        nlp.constraints(z),
        nlp.jacobian(z),
        np.atleast_1d(nlp.objective(z)),
        nlp.gradient(z),
        nlp.hessian(z, lam, 0.5),
    ]


def entries(directory):
    return sorted(p.name for p in directory.glob("*.json"))


def test_second_build_hits_the_cache_and_agrees(tmp_path):
    first = build(tmp_path)
    assert not first.cache_hit
    assert len(entries(tmp_path)) == 1
    second = build(tmp_path)
    assert second.cache_hit
    z = sample_point(first)
    for a, b in zip(evaluations(first, z), evaluations(second, z), strict=True):
        np.testing.assert_array_equal(a, b)
    assert first.nlp.jacobianstructure()[1].tolist() == second.nlp.jacobianstructure()[1].tolist()
    assert first.nlp.hessianstructure()[0].tolist() == second.nlp.hessianstructure()[0].tolist()


def test_new_data_reuses_the_build(tmp_path):
    """Measurements and known values are data: they change results, not the build."""
    first = build(tmp_path)
    other = build(tmp_path, measured=np.sin(TIMES), known={m: 2.0, g: 9.81, ell: 0.5})
    assert other.cache_hit
    z = sample_point(first)
    assert other.nlp.objective(z) != first.nlp.objective(z)
    no_cache = build(False, measured=np.sin(TIMES), known={m: 2.0, g: 9.81, ell: 0.5})
    np.testing.assert_array_equal(other.nlp.constraints(z), no_cache.nlp.constraints(z))
    assert other.nlp.objective(z) == no_cache.nlp.objective(z)


def test_a_different_structure_misses(tmp_path):
    build(tmp_path)
    assert not build(tmp_path, scheme=HermiteSimpson()).cache_hit
    assert not build(tmp_path, known={m: 1.0, g: 9.81, c: 0.1}).cache_hit  # ell unknown now
    assert len(entries(tmp_path)) == 3


def test_cache_false_never_writes(tmp_path, monkeypatch):
    monkeypatch.setenv("COLLOC_CACHE_DIR", str(tmp_path / "default"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    problem = build(False)
    again = build(False)
    assert not problem.cache_hit and not again.cache_hit
    assert list(tmp_path.rglob("*")) == []


def test_cache_true_uses_the_default_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("COLLOC_CACHE_DIR", str(tmp_path / "default"))
    assert default_cache_dir() == tmp_path / "default"
    build(True)
    assert len(entries(tmp_path / "default")) == 1
    assert build(True).cache_hit


def test_default_directory_follows_xdg(tmp_path, monkeypatch):
    monkeypatch.delenv("COLLOC_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache_dir() == tmp_path / "colloc"


@pytest.mark.parametrize(
    "content",
    ["{not json", json.dumps({"interval": {"values": "garbage"}}), json.dumps([1, 2])],
    ids=["unreadable", "stale-entry", "wrong-type"],
)
def test_corrupt_entry_is_ignored_and_rebuilt(tmp_path, content):
    reference = build(False)
    build(tmp_path)
    (path,) = tmp_path.glob("*.json")
    path.write_text(content)
    with pytest.warns(UserWarning, match=f"build cache entry {path} not used, rebuilding"):
        rebuilt = build(tmp_path)
    assert not rebuilt.cache_hit
    z = sample_point(reference, seed=3)
    for a, b in zip(evaluations(reference, z), evaluations(rebuilt, z), strict=True):
        np.testing.assert_array_equal(a, b)
    assert build(tmp_path).cache_hit  # the rebuilt entry replaced the corrupt one


def test_unwritable_cache_directory_is_not_fatal(tmp_path, caplog):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with caplog.at_level(logging.WARNING):
        problem = build(blocker)
    assert not problem.cache_hit
    assert any("could not write cache entry" in rec.getMessage() for rec in caplog.records)


def test_build_cache_round_trip_and_keys(tmp_path):
    store = BuildCache(tmp_path)
    key = cache_key(["a", "b"])
    assert store.get(key) is None
    store.put(key, {"x": [1, 2, 3]})
    assert store.get(key) == {"x": [1, 2, 3]}
    assert cache_key(["a", "b"]) == key
    assert cache_key(["ab"]) != key  # parts are separated, not concatenated
    assert cache_key(["b", "a"]) != key
    assert list(tmp_path.glob("*.tmp")) == []  # atomic write leaves no temporary file


def test_an_entry_is_used_only_when_its_signature_and_key_match(tmp_path):
    build(tmp_path)
    (path,) = tmp_path.glob("*.json")
    entry = json.loads(path.read_text())
    assert entry["format"] == 3 and entry["key"] == path.stem
    entry["payload"]["interval"] = entry["payload"]["node"]  # planted: a valid but other function
    path.write_text(json.dumps(entry))
    with pytest.warns(UserWarning, match="not signed by this user's colloc"):
        assert not build(tmp_path).cache_hit
    assert build(tmp_path).cache_hit


def test_entries_others_could_have_written_are_not_read(tmp_path):
    build(tmp_path)
    tmp_path.chmod(0o777)
    try:
        with pytest.warns(UserWarning, match="is writable by other users"):
            assert not build(tmp_path).cache_hit
    finally:
        tmp_path.chmod(0o700)
    (path,) = tmp_path.glob("*.json")
    assert path.stat().st_mode & 0o077 == 0  # entries are private
    assert build(tmp_path).cache_hit


def test_other_build_code_means_another_key(tmp_path, monkeypatch):
    """An entry built by other code (an edit without a version bump) is not found."""
    import colloc.nlp.build as build_module

    build(tmp_path)
    assert build(tmp_path).cache_hit
    monkeypatch.setattr(build_module, "_source_digest", lambda: "other code")
    assert not build(tmp_path).cache_hit
    assert len(entries(tmp_path)) == 2


def test_clear_deletes_only_entries(tmp_path):
    build(tmp_path)
    (tmp_path / "notes.json").write_text("{}")
    store = BuildCache(tmp_path)
    assert len(store.entries()) == 1
    assert store.clear() == 1
    assert [p.name for p in tmp_path.iterdir()] == ["notes.json"]  # the secret went too


def test_a_planted_entry_with_a_recomputed_checksum_is_not_loaded(tmp_path):
    """Whoever writes an entry cannot sign it: the secret is the user's, beside the entries."""
    import hashlib

    build(tmp_path)
    (path,) = tmp_path.glob("*.json")
    entry = json.loads(path.read_text())
    entry["payload"]["interval"] = entry["payload"]["node"]
    text = json.dumps(entry["payload"], sort_keys=True).encode()
    entry["hmac"] = hashlib.sha256(text).hexdigest()  # a plain checksum, as before
    path.write_text(json.dumps(entry))
    with pytest.warns(UserWarning, match="not signed by this user's colloc"):
        assert not build(tmp_path).cache_hit
    assert (tmp_path / ".key").stat().st_mode & 0o077 == 0


def _signed_entry_with(tmp_path, field, text):
    """Sign ``text`` into the cached entry's interval ``field`` as colloc would."""
    build(tmp_path)
    (path,) = tmp_path.glob("*.json")
    store = BuildCache(tmp_path)
    payload = store.get(path.stem)
    payload["interval"][field] = text
    store.put(path.stem, payload)
    return path


@pytest.mark.parametrize(
    ("field", "make", "reason"),
    [
        ("values", lambda ca: _nested(ca), "not a plain SXFunction"),
        ("jacobian", lambda ca: _jit(ca), "JIT-compiled"),
        ("hessian", lambda ca: "zz not casadi", "letters a-p"),
        ("values", lambda ca: 42, "expected a serialised function"),
    ],
    ids=["mx-with-call", "jit-on", "not-serialised", "not-text"],
)
def test_a_payload_that_is_not_a_plain_sx_function_is_refused_before_casadi_reads_it(
    tmp_path, monkeypatch, field, make, reason
):
    """Even signed, an entry holding what colloc never stores is not deserialised."""
    import casadi as ca

    path = _signed_entry_with(tmp_path, field, make(ca))
    deserialised = []
    real = ca.Function.deserialize
    monkeypatch.setattr(
        ca.Function, "deserialize", staticmethod(lambda s: deserialised.append(s) or real(s))
    )
    with pytest.warns(UserWarning, match=f"{path} not used, rebuilding: .*({reason})"):
        assert not build(tmp_path).cache_hit
    assert deserialised == [] or field != "values"  # refused before the first function
    assert all(s != make(ca) for s in deserialised)


def _nested(ca):
    x = ca.SX.sym("x")
    inner = ca.Function("inner", [x], [ca.sin(x)])
    y = ca.MX.sym("y")
    return ca.Function("outer", [y], [inner(y)]).serialize()


def _jit(ca):
    """A plain function's text with its JIT flag set (compiling needs no compiler to store)."""
    from colloc.numeric.casadi_payload import decode

    x = ca.SX.sym("x")
    stream = decode(ca.Function("f", [x], [x * x]).serialize())
    flagged = stream.replace(b"\x00\x01\x06\x00\x00\x00source", b"\x01\x01\x06\x00\x00\x00source")
    assert flagged != stream
    return "".join(chr(97 + (b & 15)) + chr(97 + (b >> 4)) for b in flagged)


def test_plain_functions_pass_the_payload_check():
    import casadi as ca

    from colloc.numeric.casadi_payload import decode, plain_function_problem

    x = ca.SX.sym("x", 3)
    f = ca.Function("f", [x], [ca.sin(x) * x[0]])
    assert plain_function_problem(f.serialize()) is None
    jac = ca.Function("f_jac", [x], [ca.jacobian(f(x), x)])  # as colloc builds them
    assert plain_function_problem(jac.serialize()) is None
    assert "2 functions" in plain_function_problem(f.jacobian().serialize())  # holds f too
    text = f.serialize()
    encoded_again = "".join(chr(97 + (b & 15)) + chr(97 + (b >> 4)) for b in decode(text))
    assert encoded_again == text  # the decoding is CasADi's, byte for byte
