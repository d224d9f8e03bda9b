"""Filter, inverse kinematics and inverse dynamics against references: analytic signals, the
forward kinematics of gait2d, and GaitAnalysisToolKit's leg2d on real walking.

``refresults.mat`` is leg2d's output for ``rawdata.txt`` as committed in 2013 (see the data's
SOURCE.md): it was made with a 4 Hz cut-off (its test script says 6 Hz), and before the fix
of 2014-04-02 that gave every segment its own mass, so its hip and knee moments use the foot's
mass and radius of gyration for thigh and shank. A re-implementation of that leg2d (outside
this project) reproduces the file to 1e-14 with those two facts; these tests compare with it
on those terms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

from colloc.lab import (
    DEFAULT_MARKER_SET,
    LEG2D_SIGNS,
    LegInertia,
    angles_from_leg2d,
    dual_pass_correction,
    fill_gaps,
    joint_angles,
    leg_inverse_dynamics,
    read_lab_export,
    segment_orientations,
    time_derivative,
    zero_lag_lowpass,
)
from colloc.models.gait2d_params import load_parameters
from colloc.models.gait2d_points import StickFigureGeometry, stick_figure_points

RECORDS = Path(__file__).resolve().parents[1] / "data" / "records" / "gatk-leg2d-sagittal-gait-3s"
MASS = 67.2  # subject 7 of the HBM paper (leg2d's test)
REFERENCE_CUTOFF = 4.0  # what refresults.mat was computed with
RIGHT = DEFAULT_MARKER_SET.side_markers("right")  # RSHO, RGTRO, RLEK, RLM, RHEE, RMT5


def test_two_passes_are_minus_3_db_at_the_cutoff_without_lag():
    rate, cutoff = 100.0, 6.0
    time = np.arange(4000) / rate
    for frequency, gain in ((cutoff, 2**-0.5), (1.0, None)):
        signal = np.sin(2 * np.pi * frequency * time)
        out = zero_lag_lowpass(signal, rate, cutoff)[1000:-1000]
        basis = np.column_stack(
            [np.sin(2 * np.pi * frequency * time), np.cos(2 * np.pi * frequency * time)]
        )[1000:-1000]
        (a, b), *_ = np.linalg.lstsq(basis, out, rcond=None)
        assert abs(b) < 1e-9  # zero phase: no cosine part
        if gain is not None:
            assert a == pytest.approx(gain, rel=1e-6)
        else:
            assert a == pytest.approx(1.0, abs=0.01)
    assert dual_pass_correction(2) == pytest.approx(0.802, abs=5e-4)  # Winter's factor
    with pytest.raises(ValueError, match="Nyquist"):
        zero_lag_lowpass(np.zeros(100), rate, 50.0)
    with pytest.raises(ValueError, match="NaN"):
        zero_lag_lowpass(np.full(100, np.nan), rate)


def test_central_differences_converge_at_second_order_including_the_ends():
    errors = []
    for rate in (50.0, 100.0, 200.0):
        time = np.arange(int(2 * rate) + 1) / rate
        errors.append(np.abs(time_derivative(np.sin(3 * time), rate) - 3 * np.cos(3 * time)).max())
    assert np.log2(errors[0] / errors[1]) == pytest.approx(2.0, abs=0.15)
    assert np.log2(errors[1] / errors[2]) == pytest.approx(2.0, abs=0.15)


def test_inverse_kinematics_recovers_gait2d_coordinates_from_its_own_landmarks():
    params = load_parameters(75.0, 1.8)
    # a continuous motion through wide angles (trunk +-0.3 rad, joints up to 1.6 rad)
    t = np.linspace(0.0, 2.0, 201)[:, None]
    amplitude = np.array([0.05, 0.05, 0.3, 1.0, 0.8, 0.6, 1.0, 0.8, 0.6])
    q = amplitude * np.sin(2 * np.pi * t * np.arange(1, 10) / 3)
    q[:, 4] -= 0.8  # knees flexed (negative)
    q[:, 7] -= 0.8
    points = stick_figure_points(q, StickFigureGeometry.from_parameters(params))
    for side, columns in (("right", slice(3, 6)), ("left", slice(6, 9))):
        landmarks = {
            "shoulder": points["trunk_top"],
            "hip": points["hip"],
            **{name: points[f"{side}_{name}"] for name in ("knee", "ankle", "heel", "toe")},
        }
        orientations = segment_orientations(landmarks)
        assert orientations["trunk"] == pytest.approx(q[:, 2], abs=1e-12)
        assert joint_angles(orientations) == pytest.approx(q[:, columns], abs=1e-12)


def _right_leg(cutoff: float) -> tuple[dict, dict, np.ndarray, np.ndarray]:
    export = read_lab_export(RECORDS / "rawdata.txt")
    filled, _, span = fill_gaps(export.time, export.markers)
    assert span == slice(0, 301)
    landmarks = {
        k: zero_lag_lowpass(filled[v], export.sample_rate, cutoff) for k, v in RIGHT.items()
    }
    load = zero_lag_lowpass(export.plates["FP2"], export.sample_rate, cutoff)
    stance = export.plates["FP2"][:, 1] > 20.0
    return landmarks, segment_orientations(landmarks), load, stance


def _rms(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(x**2, axis=0))


def test_angles_and_rates_match_leg2d_on_real_walking():
    reference = loadmat(RECORDS / "refresults.mat")["refresults"]
    _, orientations, _, _ = _right_leg(REFERENCE_CUTOFF)
    angles = joint_angles(orientations)
    rates = time_derivative(angles, 100.0)
    # measured: 0.058, 0.054, 0.060 deg RMS (bar: 1 deg)
    assert np.degrees(_rms(angles - angles_from_leg2d(reference[:, :3]))).max() < 0.1
    # measured: 4.0, 0.7, 2.6 % of the RMS rate, most of it in leg2d's first 0.2 s, where its
    # filter starts from rest (0.3-0.5 % after them); bar: 5 %
    expected = reference[:, 3:6] * LEG2D_SIGNS
    relative = _rms(rates - expected) / _rms(expected)
    assert relative.max() < 0.045
    assert (_rms((rates - expected)[20:-20]) / _rms(expected[20:-20])).max() < 0.01


def test_moments_match_leg2d_over_stance_on_its_own_segment_table_and_the_ankle_on_ours():
    reference = loadmat(RECORDS / "refresults.mat")["refresults"]
    expected = reference[:, 6:9] * LEG2D_SIGNS  # N m/kg
    landmarks, orientations, load, stance = _right_leg(REFERENCE_CUTOFF)
    lengths = [
        np.linalg.norm(landmarks[b] - landmarks[a], axis=1).mean()
        for a, b in (("hip", "knee"), ("knee", "ankle"), ("heel", "toe"))
    ]
    # gait2d's segments (Winter's fractions) for a height whose thigh is the measured one
    params = load_parameters(MASS, lengths[0] / 0.245)
    ours = leg_inverse_dynamics(
        landmarks, orientations, load, LegInertia.from_parameters(params), 100.0
    )
    error = _rms((ours.torques / MASS - expected)[stance])
    # measured 0.057 / 0.017 / 0.008 N m/kg: the ankle agrees; hip and knee differ by the
    # reference's thigh and shank masses (the foot's), as the next check shows
    assert error[2] < 0.015 and error[1] < 0.03
    assert 0.04 < error[0] < 0.08
    # leg2d-2013's table: every segment with the foot's mass fraction 0.0145 and radius of
    # gyration 0.475 of its marker length; the foot's centre of mass midway along heel-toe
    foot = 0.0145 * MASS
    mid = 0.5 * (landmarks["heel"] + landmarks["toe"]) - landmarks["ankle"]
    c, s = np.cos(orientations["foot"]), np.sin(orientations["foot"])
    offset = np.column_stack([c * mid[:, 0] + s * mid[:, 1], c * mid[:, 1] - s * mid[:, 0]]).mean(
        axis=0
    )
    table = LegInertia(
        masses=(foot, foot, foot),
        inertias=tuple(foot * (0.475 * length) ** 2 for length in lengths),
        thigh_com=0.433,
        shank_com=0.433,
        foot_com=(float(offset[0]), float(offset[1])),
        gravity=9.81,
    )
    theirs = leg_inverse_dynamics(landmarks, orientations, load, table, 100.0)
    # measured 0.024 / 0.013 / 0.006 N m/kg (bar: 0.05): the rest is the filters' start-up and
    # derivatives (leg2d differentiates its filter's state)
    assert _rms((theirs.torques / MASS - expected)[stance]).max() < 0.035


def test_inverse_dynamics_of_a_static_leg_is_statics():
    """A leg held still, foot loaded by a known force at a known point: the joint torques are
    the moments of that force and the segments' weights about each joint."""
    params = load_parameters(75.0, 1.8)
    inertia = LegInertia.from_parameters(params)
    n = 40
    hip, knee, ankle = np.array([0.1, 0.9]), np.array([0.15, 0.47]), np.array([0.05, 0.08])
    landmarks = {
        "hip": np.tile(hip, (n, 1)),
        "knee": np.tile(knee, (n, 1)),
        "ankle": np.tile(ankle, (n, 1)),
    }
    foot_angle = 0.1
    orientations = {
        "thigh": np.full(n, 0.0),  # only the foot's is used for its centre of mass
        "shank": np.full(n, 0.0),
        "foot": np.full(n, foot_angle),
    }
    force, cop = np.array([30.0, 700.0]), 0.12
    load = np.tile([force[0], force[1], cop * force[1]], (n, 1))
    torques = leg_inverse_dynamics(landmarks, orientations, load, inertia, 100.0).torques
    g = params.gravity
    c, s = np.cos(foot_angle), np.sin(foot_angle)
    foot_com = ankle + np.array(
        [
            c * inertia.foot_com[0] - s * inertia.foot_com[1],
            s * inertia.foot_com[0] + c * inertia.foot_com[1],
        ]
    )
    coms = [
        hip + inertia.thigh_com * (knee - hip),
        knee + inertia.shank_com * (ankle - knee),
        foot_com,
    ]

    def moment_on_distal(joint: np.ndarray, segments: range) -> float:
        # the proximal segment holds everything below the joint still: it balances the ground
        # force's and the weights' moments about the joint
        total = (cop - joint[0]) * force[1] - (0.0 - joint[1]) * force[0]
        for k in segments:
            total += (coms[k][0] - joint[0]) * (-inertia.masses[k] * g)
        return -total

    expected = [
        moment_on_distal(hip, range(3)),
        moment_on_distal(knee, range(1, 3)),
        moment_on_distal(ankle, range(2, 3)),
    ]
    assert torques[n // 2] == pytest.approx(expected, abs=1e-9)
