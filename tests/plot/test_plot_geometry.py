"""link_positions: hand-computed points, and consistency with the study's equations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from colloc.plot import PlotInputError, link_positions


def test_one_link_hand_computed():
    assert np.allclose(link_positions([0.5, 0.0], [2.0]), [[0.5, 0.0], [0.5, 2.0]])
    # A positive angle tips the link to the left (counter-clockwise about +z).
    assert np.allclose(link_positions([0.5, math.pi / 2], [2.0]), [[0.5, 0.0], [-1.5, 0.0]])
    assert np.allclose(link_positions([0.0, math.pi], [1.0]), [[0.0, 0.0], [0.0, -1.0]])


def test_two_links_hand_computed():
    positions = link_positions([0.2, math.pi / 6, -math.pi / 4], [1.0, 0.5])
    # mass 1: (0.2 - sin 30°, cos 30°); mass 2 adds 0.5 * (-sin(-45°), cos(-45°)).
    expected = [
        [0.2, 0.0],
        [0.2 - 0.5, 0.8660254037844386],
        [0.2 - 0.5 + 0.5 * 0.7071067811865476, 0.8660254037844386 + 0.5 * 0.7071067811865476],
    ]
    assert np.allclose(positions, expected, rtol=0, atol=1e-15)


def test_leading_dimensions_are_kept():
    rng = np.random.default_rng(4)
    q = rng.normal(size=(5, 3, 4))
    lengths = [1.0, 0.7, 0.4]
    stacked = link_positions(q, lengths)
    assert stacked.shape == (5, 3, 4, 2)
    assert np.array_equal(stacked[2, 1], link_positions(q[2, 1], lengths))


def _fd_jacobian(function, q, step=1e-6):
    columns = []
    for k in range(q.size):
        dq = np.zeros_like(q)
        dq[k] = step
        columns.append((function(q + dq) - function(q - dq)) / (2 * step))
    return np.stack(columns, axis=-1)


def test_positions_reproduce_the_study_one_link_equations():
    """Mass matrix, gravity and velocity terms from the positions match the seed's model."""
    m0, m1, l0, g = 1.3, 0.7, 1.1, 9.81
    q = np.array([0.4, 0.6])
    u = np.array([0.3, -1.2])

    def mass_position(coordinates):
        return link_positions(coordinates, [l0])[1]

    def cart_position(coordinates):
        return link_positions(coordinates, [l0])[0]

    jacobian = _fd_jacobian(mass_position, q)
    cart_jacobian = _fd_jacobian(cart_position, q)
    mass_matrix = m0 * cart_jacobian.T @ cart_jacobian + m1 * jacobian.T @ jacobian
    expected_mass = [[m0 + m1, -l0 * m1 * math.cos(q[1])], [-l0 * m1 * math.cos(q[1]), l0**2 * m1]]
    assert np.allclose(mass_matrix, expected_mass, atol=1e-8)

    gravity = m1 * g * jacobian[1]  # d(m1 g y1)/dq
    assert np.allclose(gravity, [0.0, -g * l0 * m1 * math.sin(q[1])], atol=1e-7)

    # Velocity-product terms: m1 J^T (d^2 p / dt^2 at zero acceleration).
    h = 1e-4
    curvature = (mass_position(q + h * u) + mass_position(q - h * u) - 2 * mass_position(q)) / h**2
    velocity_terms = m1 * jacobian.T @ curvature
    assert np.allclose(velocity_terms, [l0 * m1 * u[1] ** 2 * math.sin(q[1]), 0.0], atol=1e-5)


def test_shape_problems_are_reported_together():
    with pytest.raises(PlotInputError, match="1 problem") as caught:
        link_positions([[0.0, 0.1]], [1.0, 2.0])
    assert "coordinates: expected a last dimension of n + 1 = 3" in str(caught.value)
    with pytest.raises(PlotInputError, match="2 problem") as caught:
        link_positions(0.0, [[1.0]])
    assert "lengths: expected a 1-D array" in str(caught.value)
    with pytest.raises(PlotInputError, match=r"lengths: expected finite non-negative values"):
        link_positions([0.0, 0.1], [-1.0])
