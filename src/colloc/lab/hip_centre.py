"""The hip joint centre from pelvis markers, by Harrington et al.'s regression.

No skin marker sits on the hip joint; labs place it from the pelvis markers. Harrington,
Zavatsky, Lawson, Yuan and Theologis (2007, J Biomech 40:595-602) regressed the centre on
the pelvis width ``PW`` (between the anterior superior iliac spines, ASIS) and depth ``PD``
(from the ASIS midpoint to the posterior spines' midpoint) in the pelvis frame (origin at
the ASIS midpoint, x anterior, y superior, z to the right), in millimetres:

.. math::

    x = -0.24\\,PD - 9.9, \\qquad y = -0.30\\,PW - 10.9, \\qquad z = \\pm(0.33\\,PW + 7.3)

A sacral marker stands for the posterior spines' midpoint when the set has no PSIS markers.
"""

from __future__ import annotations

import numpy as np

#: Harrington's coefficients: (per PD, per PW, offset [mm]) for x, y and |z|.
HARRINGTON: dict[str, tuple[float, float, float]] = {
    "anterior": (-0.24, 0.0, -9.9),
    "superior": (0.0, -0.30, -10.9),
    "lateral": (0.0, 0.33, 7.3),
}


def hip_joint_centres(
    right_asis: np.ndarray, left_asis: np.ndarray, posterior: np.ndarray, up: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Right and left hip joint centres at each frame [m].

    Parameters
    ----------
    right_asis, left_asis : ndarray, shape (N, 3)
        The anterior superior iliac spines [m].
    posterior : ndarray, shape (N, 3)
        The posterior spines' midpoint (or a sacral marker) [m].
    up : ndarray, shape (3,)
        The lab's vertical, to tell the pelvis' superior side.

    Returns
    -------
    right, left : ndarray, shape (N, 3)
        NaN where a marker is.
    """
    middle = 0.5 * (right_asis + left_asis)
    lateral = right_asis - left_asis
    width = np.linalg.norm(lateral, axis=1, keepdims=True)
    z = lateral / width
    backward = posterior - middle
    depth = np.linalg.norm(backward, axis=1, keepdims=True)
    x = -(backward - np.sum(backward * z, axis=1, keepdims=True) * z)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    # the pelvis' superior axis points up in a lab (a subject upside down is no walk)
    flip = np.sign(y @ up)[:, None]
    y *= np.where(flip == 0, 1.0, flip)
    pw, pd = 1000.0 * width, 1000.0 * depth

    def along(name: str) -> np.ndarray:
        per_depth, per_width, offset = HARRINGTON[name]
        return (per_depth * pd + per_width * pw + offset) / 1000.0

    base = middle + along("anterior") * x + along("superior") * y
    return base + along("lateral") * z, base - along("lateral") * z
