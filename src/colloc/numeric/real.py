"""Numbers handed to the library as real arrays: complex values are refused, not cut.

``np.asarray(values, dtype=float)`` turns ``1+2j`` into ``1.0`` with only a NumPy
``ComplexWarning``; data with an imaginary part is a mistake upstream, not a real signal.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def real_array(values: Any) -> np.ndarray:
    """``values`` as a float array.

    Parameters
    ----------
    values : array-like of real numbers

    Returns
    -------
    ndarray of float

    Raises
    ------
    TypeError
        For complex values (named as such), text, or anything NumPy cannot make numbers of.
    ValueError
        For ragged sequences.
    """
    raw = np.asarray(values)
    if np.iscomplexobj(raw):
        raise TypeError("complex numbers (an imaginary part): expected real ones")
    return np.asarray(raw, dtype=float)
