"""Package attributes imported on first use (PEP 562), so ``import colloc`` stays cheap.

A package lists what it exports and the module that defines each name; the module is
imported when the name is first read, and the value is then kept in the package's namespace.
Heavy libraries (pandas, matplotlib, SQLAlchemy, SciPy's signal module) are thereby loaded only
by the commands and functions that use them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(
    package: str, exports: Mapping[str, str], namespace: dict[str, Any]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package whose exports load on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping
        Exported name -> module defining it (the name itself when it is a submodule).
    namespace : dict
        The package's ``globals()``; loaded values are cached there.

    Returns
    -------
    __getattr__, __dir__ : callable
    """

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        loaded = importlib.import_module(module)
        value = loaded if module == f"{package}.{name}" else getattr(loaded, name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *exports})

    return __getattr__, __dir__
