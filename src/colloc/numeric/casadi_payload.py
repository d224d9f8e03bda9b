"""What a serialised CasADi function holds, read before CasADi deserialises it.

Deserialising a CasADi function can load native code: an ``External`` loads a shared
library, a function with ``jit`` on compiles and loads C code, a plugin is a shared library
found by name. The build cache stores only plain ``SXFunction`` objects with JIT off and no
function nested inside (:meth:`colloc.numeric.stencil.StencilFunctions.to_bytes`), so a
payload that is anything else was not written by colloc and is refused here, from the bytes,
before CasADi sees it. The cache's signature (:class:`colloc.numeric.cache.BuildCache`) is
the first guard; this is the second.
"""

from __future__ import annotations

import re
from functools import cache

import casadi as ca

#: Classes whose deserialisation loads or compiles native code, or that nest other functions.
_REFUSED_CLASSES = (
    "External",
    "GenericExternal",
    "JitFunction",
    "FmuFunction",
    "Importer",
    "DllLibrary",
    "JitLibrary",
    "ShellCompiler",
    "ClangCompiler",
    "MXFunction",
    "Map",
    "OmpMap",
    "ThreadMap",
    "Switch",
)

#: The JIT fields every function writes: jit flag, cleanup flag, then how code is kept.
_JIT_FIELDS = re.compile(
    rb"[\x00\x01][\x00\x01](?:\x06\x00\x00\x00source|\x04\x00\x00\x00link|\x05\x00\x00\x00embed)"
)


def decode(text: str) -> bytes:
    """The bytes of CasADi's text serialisation (two letters ``a``-``p`` per byte, low first).

    Parameters
    ----------
    text : str

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        When ``text`` is not of that form.
    """
    if len(text) % 2 or text.strip("abcdefghijklmnop"):
        raise ValueError("not CasADi's text serialisation (letters a-p in pairs)")
    raw = text.encode("ascii")
    return bytes(((raw[i + 1] - 97) << 4) | (raw[i] - 97) for i in range(0, len(raw), 2))


@cache
def _reference() -> tuple[bytes, bytes]:
    """This CasADi's header up to the class name, and the JIT fields of a plain function."""
    x = ca.SX.sym("x")
    stream = decode(ca.Function("f", [x], [2 * x]).serialize())
    name = b"\x0a\x00\x00\x00SXFunction"
    header = stream[: stream.index(name) + len(name)]
    match = _JIT_FIELDS.search(stream)
    assert match is not None, "CasADi's serialisation changed: update casadi_payload"
    return header, match.group()


def plain_function_problem(text: object) -> str | None:
    """Why ``text`` is not one plain SX function with JIT off (None when it is).

    Parameters
    ----------
    text : object
        A payload as the cache stores it: CasADi's text serialisation of a function.

    Returns
    -------
    str or None
    """
    if not isinstance(text, str):
        return f"expected a serialised function (text), found {type(text).__name__}"
    try:
        stream = decode(text)
    except ValueError as exc:
        return str(exc)
    header, plain_jit = _reference()
    if not stream.startswith(header):
        return "not a plain SXFunction serialised by this CasADi"
    jit_fields = _JIT_FIELDS.findall(stream)
    if len(jit_fields) != 1:
        return f"holds {len(jit_fields)} functions' settings, expected one (no nested function)"
    if jit_fields[0] != plain_jit:
        return "asks for JIT-compiled or embedded native code"
    for name in _REFUSED_CLASSES:
        if len(name).to_bytes(4, "little") + name.encode() in stream:
            return f"holds a {name}, which colloc never stores"
    return None
