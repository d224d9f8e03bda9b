"""IPOPT's C interface through ctypes: each callback hands IPOPT its values in one memmove.

cyipopt's value callbacks copy every Jacobian and Hessian nonzero through a Python-level
index (``values[i] = np_h[i]`` on an untyped array, in ``ipopt_wrapper.pyx``), which the
measurements of issue 9 put at 2-8x colloc's own evaluation time. The same IPOPT library
that ``cyipopt-wheels`` ships (``cyipopt_wheels.libs/libipopt-*.so``) exports the C
interface (``IpStdCInterface.h``), so this module drives it directly with ctypes: no
compiler, the same IPOPT build, and the arrays colloc computes are copied into IPOPT's
buffers with one ``memmove`` each.
"""

from __future__ import annotations

import ctypes
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from colloc.solve.result import Evaluations

_index = ctypes.c_int
_number = ctypes.c_double
_bool = ctypes.c_bool
_p_number = ctypes.POINTER(_number)
_p_index = ctypes.POINTER(_index)

_EVAL_F = ctypes.CFUNCTYPE(_bool, _index, _p_number, _bool, _p_number, ctypes.c_void_p)
_EVAL_GRAD_F = ctypes.CFUNCTYPE(_bool, _index, _p_number, _bool, _p_number, ctypes.c_void_p)
_EVAL_G = ctypes.CFUNCTYPE(_bool, _index, _p_number, _bool, _index, _p_number, ctypes.c_void_p)
_EVAL_JAC_G = ctypes.CFUNCTYPE(
    _bool, _index, _p_number, _bool, _index, _index, _p_index, _p_index, _p_number, ctypes.c_void_p
)
_EVAL_H = ctypes.CFUNCTYPE(
    _bool,
    _index,
    _p_number,
    _bool,
    _number,
    _index,
    _p_number,
    _bool,
    _index,
    _p_index,
    _p_index,
    _p_number,
    ctypes.c_void_p,
)
_INTERMEDIATE = ctypes.CFUNCTYPE(
    _bool,
    _index,
    _index,
    _number,
    _number,
    _number,
    _number,
    _number,
    _number,
    _number,
    _number,
    _index,
    ctypes.c_void_p,
)


class Callbacks(Evaluations, Protocol):
    """What :class:`CProblem` calls: cyipopt's ``problem_obj`` interface."""

    def intermediate(self, *args: Any) -> bool: ...  # noqa: D102


def library_path() -> Path:
    """The IPOPT shared library bundled with ``cyipopt-wheels``.

    Raises
    ------
    FileNotFoundError
        When the wheel's library folder holds no ``libipopt`` (another cyipopt build).
    """
    import cyipopt

    folder = Path(cyipopt.__file__).resolve().parent.parent / "cyipopt_wheels.libs"
    found = sorted(folder.glob("libipopt*.so*")) + sorted(folder.glob("*ipopt*.dll"))
    if not found:
        raise FileNotFoundError(f"no IPOPT library in {folder} (is cyipopt-wheels installed?)")
    return found[0]


_LIBRARY: ctypes.CDLL | None = None


def _library() -> ctypes.CDLL:
    global _LIBRARY
    if _LIBRARY is None:
        lib = ctypes.CDLL(str(library_path()))
        lib.CreateIpoptProblem.restype = ctypes.c_void_p
        lib.CreateIpoptProblem.argtypes = [
            _index,
            _p_number,
            _p_number,
            _index,
            _p_number,
            _p_number,
            _index,
            _index,
            _index,
            _EVAL_F,
            _EVAL_G,
            _EVAL_GRAD_F,
            _EVAL_JAC_G,
            _EVAL_H,
        ]
        lib.FreeIpoptProblem.argtypes = [ctypes.c_void_p]
        lib.FreeIpoptProblem.restype = None
        for name, kind in (
            ("AddIpoptStrOption", ctypes.c_char_p),
            ("AddIpoptNumOption", _number),
            ("AddIpoptIntOption", _index),
        ):
            getattr(lib, name).argtypes = [ctypes.c_void_p, ctypes.c_char_p, kind]
            getattr(lib, name).restype = _bool
        lib.SetIntermediateCallback.argtypes = [ctypes.c_void_p, _INTERMEDIATE]
        lib.SetIntermediateCallback.restype = _bool
        lib.IpoptSolve.argtypes = [
            ctypes.c_void_p,
            _p_number,
            _p_number,
            _p_number,
            _p_number,
            _p_number,
            _p_number,
            ctypes.c_void_p,
        ]
        lib.IpoptSolve.restype = ctypes.c_int
        _LIBRARY = lib
    return _LIBRARY


def _pointer(a: np.ndarray) -> Any:
    return a.ctypes.data_as(_p_number)


def _copy_into(target: Any, values: np.ndarray, count: int, what: str) -> None:
    arr = np.ascontiguousarray(values, dtype=float).ravel()
    if arr.size != count:
        raise ValueError(f"{what}: expected {count} values, found {arr.size}")
    ctypes.memmove(target, arr.ctypes.data, arr.nbytes)


def _copy_pattern(rows: Any, cols: Any, pattern: tuple[np.ndarray, np.ndarray]) -> bool:
    ctypes.memmove(rows, pattern[0].ctypes.data, pattern[0].nbytes)
    ctypes.memmove(cols, pattern[1].ctypes.data, pattern[1].nbytes)
    return True


class CProblem:
    """``min f(x) s.t. cl <= g(x) <= cu, lb <= x <= ub`` solved by IPOPT's C interface.

    Parameters
    ----------
    n, m : int
        Numbers of variables and constraints.
    callbacks : Callbacks
        Values, derivatives, sparsity patterns (lower-triangle Hessian) and the
        per-iteration ``intermediate`` callback, as for ``cyipopt.Problem``.
    lb, ub, cl, cu : ndarray
        Bounds of the variables and of the constraints.
    """

    def __init__(
        self,
        n: int,
        m: int,
        callbacks: Callbacks,
        lb: np.ndarray,
        ub: np.ndarray,
        cl: np.ndarray,
        cu: np.ndarray,
    ) -> None:
        lib = _library()
        self._cb = callbacks
        self.n, self.m = int(n), int(m)
        self._exception: tuple[Any, ...] | None = None
        jr, jc = callbacks.jacobianstructure()
        hr, hc = callbacks.hessianstructure()
        self._jac = (np.asarray(jr, np.int32), np.asarray(jc, np.int32))
        self._hess = (np.asarray(hr, np.int32), np.asarray(hc, np.int32))
        self._bounds = [np.ascontiguousarray(b, dtype=float) for b in (lb, ub, cl, cu)]
        # the ctypes function objects must outlive the problem
        self._functions = (
            _EVAL_F(self._guard(self._f)),
            _EVAL_G(self._guard(self._g)),
            _EVAL_GRAD_F(self._guard(self._grad)),
            _EVAL_JAC_G(self._guard(self._jacobian)),
            _EVAL_H(self._guard(self._hessian)),
            _INTERMEDIATE(self._guard(self._intermediate)),
        )
        lb_, ub_, cl_, cu_ = self._bounds
        self._handle = lib.CreateIpoptProblem(
            self.n,
            _pointer(lb_),
            _pointer(ub_),
            self.m,
            _pointer(cl_),
            _pointer(cu_),
            int(self._jac[0].size),
            int(self._hess[0].size),
            0,
            *self._functions[:5],
        )
        if not self._handle:
            raise RuntimeError("IPOPT refused the problem definition (CreateIpoptProblem)")
        lib.SetIntermediateCallback(self._handle, self._functions[5])

    # ------------------------------------------------------------------ callbacks
    def _guard(self, fn: Callable[..., bool]) -> Callable[..., bool]:
        """Keep a callback's exception for :meth:`solve` to raise, and stop IPOPT."""

        def call(*args: Any) -> bool:
            if self._exception is not None:
                return False
            try:
                return fn(*args)
            except BaseException:  # includes Ctrl-C, re-raised after IPOPT returns
                self._exception = sys.exc_info()
                return False

        return call

    def _x(self, n: int, x: Any) -> np.ndarray:
        return np.ctypeslib.as_array(x, shape=(n,)).copy()

    def _f(self, n: int, x: Any, new_x: bool, obj: Any, _: Any) -> bool:
        obj[0] = float(self._cb.objective(self._x(n, x)))
        return True

    def _grad(self, n: int, x: Any, new_x: bool, out: Any, _: Any) -> bool:
        _copy_into(out, self._cb.gradient(self._x(n, x)), n, "gradient")
        return True

    def _g(self, n: int, x: Any, new_x: bool, m: int, out: Any, _: Any) -> bool:
        _copy_into(out, self._cb.constraints(self._x(n, x)), m, "constraints")
        return True

    def _jacobian(self, *args: Any) -> bool:
        # (n, x, new_x, m, nele_jac, iRow, jCol, values, user_data), as Eval_Jac_G_CB
        n, x, _, _, nele, rows, cols, values, _ = args
        if not values:
            return _copy_pattern(rows, cols, self._jac)
        _copy_into(values, self._cb.jacobian(self._x(n, x)), nele, "jacobian")
        return True

    def _hessian(self, *args: Any) -> bool:
        # (n, x, new_x, obj_factor, m, lambda, new_lambda, nele_hess, iRow, jCol, values,
        # user_data), as Eval_H_CB
        n, x, _, obj_factor, m, lam, _, nele, rows, cols, values, _ = args
        if not values:
            return _copy_pattern(rows, cols, self._hess)
        lagrange = np.ctypeslib.as_array(lam, shape=(m,)).copy() if m else np.zeros(0)
        _copy_into(values, self._cb.hessian(self._x(n, x), lagrange, obj_factor), nele, "hessian")
        return True

    def _intermediate(self, *args: Any) -> bool:
        return bool(self._cb.intermediate(*args[:11]))

    # ------------------------------------------------------------------ driving
    def add_option(self, key: str, value: Any) -> None:
        """Set one IPOPT option.

        Raises
        ------
        TypeError
            When IPOPT refuses the option or its value.
        """
        lib = _library()
        name = key.encode()
        if isinstance(value, bool) or isinstance(value, str):
            text = ("yes" if value else "no") if isinstance(value, bool) else value
            ok = lib.AddIpoptStrOption(self._handle, name, text.encode())
        elif isinstance(value, int | np.integer):
            ok = lib.AddIpoptIntOption(self._handle, name, int(value))
        elif isinstance(value, float | np.floating):
            ok = lib.AddIpoptNumOption(self._handle, name, float(value))
        else:
            raise TypeError(f"unsupported option value type {type(value).__name__}")
        if not ok:
            raise TypeError(f"IPOPT refused option {key}={value!r}")

    def solve(self, x0: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        """Run IPOPT from ``x0``; ``(x, info)`` with ``status``, ``obj_val``, ``g``, ``mult_g``.

        An exception raised in a callback (Ctrl-C included) stops IPOPT and is re-raised
        here, after IPOPT has returned.
        """
        x = np.array(x0, dtype=float)
        if x.shape != (self.n,):
            raise ValueError(f"x0: expected shape ({self.n},), found {x.shape}")
        g = np.zeros(self.m)
        obj = np.zeros(1)
        mult_g = np.zeros(self.m)
        mult_l = np.zeros(self.n)
        mult_u = np.zeros(self.n)
        self._exception = None
        status = _library().IpoptSolve(
            self._handle,
            _pointer(x),
            _pointer(g),
            _pointer(obj),
            _pointer(mult_g),
            _pointer(mult_l),
            _pointer(mult_u),
            None,
        )
        if self._exception is not None:
            _, error, trace = self._exception
            self._exception = None
            raise error.with_traceback(trace)
        info = {
            "status": int(status),
            "obj_val": float(obj[0]),
            "g": g,
            "mult_g": mult_g,
            "mult_x_L": mult_l,
            "mult_x_U": mult_u,
        }
        return x, info

    def close(self) -> None:
        """Free IPOPT's problem (also when a solve failed)."""
        if self._handle:
            _library().FreeIpoptProblem(self._handle)
            self._handle = None
