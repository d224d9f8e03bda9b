"""Winter scaling of the gait2d segment parameters and validation of the YAML file."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from colloc.models.gait2d_params import (
    DEFAULT_PARAMETER_FILE,
    ParameterFileError,
    load_parameters,
)


def test_winter_scaling_reproduces_gait2d_numbers():
    # Reference values: van den Bogert's gait2d parameter set for 75 kg, 1.80 m (Winter).
    p = load_parameters(75.0, 1.80)
    assert p.thigh.mass == pytest.approx(7.5, abs=1e-12)
    assert p.thigh.inertia == pytest.approx(0.1522, abs=5e-5)
    assert p.thigh.length == pytest.approx(0.441, abs=1e-12)
    assert p.thigh.com == pytest.approx(0.1910, abs=5e-5)
    assert p.trunk.mass == pytest.approx(50.85, abs=1e-12)
    assert p.trunk.inertia == pytest.approx(3.1777, abs=5e-5)
    assert p.trunk.com == pytest.approx(0.3155, abs=5e-5)
    assert p.shank.mass == pytest.approx(3.4875, abs=1e-12)
    assert p.shank.inertia == pytest.approx(0.0624, abs=5e-5)
    assert p.shank.length == pytest.approx(0.4428, abs=1e-12)
    assert p.shank.com == pytest.approx(0.1917, abs=5e-5)
    assert p.foot.mass == pytest.approx(1.0875, abs=1e-12)
    assert p.foot.inertia == pytest.approx(0.0184, abs=5e-5)
    assert p.foot_com_x == pytest.approx(0.0768, abs=5e-5)
    assert p.foot_com_y == pytest.approx(0.0351, abs=5e-5)
    assert p.heel_x == pytest.approx(-0.06, abs=1e-4)
    assert p.toe_x == pytest.approx(0.15, abs=1e-4)
    assert p.ankle_height == pytest.approx(0.0702, abs=1e-12)
    assert p.contact.stiffness == 5e7
    assert p.contact.damping == 0.85
    assert p.contact.friction_coefficient == 1.0
    assert p.contact.friction_velocity == 0.01


def test_total_mass_and_scaling_with_subject():
    p = load_parameters(62.0, 1.65)
    assert p.total_mass == pytest.approx(62.0 * (0.678 + 2 * (0.1 + 0.0465 + 0.0145)), rel=1e-14)
    # mass scales linearly, inertia with mass * height^2
    ref = load_parameters(75.0, 1.80)
    ratio = (62.0 / 75.0) * (1.65 / 1.80) ** 2
    assert p.shank.inertia == pytest.approx(ref.shank.inertia * ratio, rel=1e-12)
    assert p.shank.length == pytest.approx(0.246 * 1.65, rel=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"body_mass": -1.0}, r"body_mass: expected a positive finite number, found -1\.0"),
        ({"height": math.nan}, r"height: expected a positive finite number, found nan"),
        ({"body_mass": "75"}, r"body_mass: expected a positive finite number, found '75'"),
    ],
)
def test_bad_subject_raises(kwargs, match):
    with pytest.raises(ValueError, match=match):
        load_parameters(**kwargs)


def test_missing_file_raises(tmp_path: Path):
    with pytest.raises(FileNotFoundError, match="path: expected an existing gait2d YAML file"):
        load_parameters(path=tmp_path / "nope.yaml")


def _write(tmp_path: Path, data) -> Path:
    file = tmp_path / "params.yaml"
    file.write_text(yaml.safe_dump(data), encoding="utf-8")
    return file


def test_every_problem_in_file_is_reported_at_once(tmp_path: Path):
    data = yaml.safe_load(DEFAULT_PARAMETER_FILE.read_text(encoding="utf-8"))
    del data["segments"]["shank"]
    del data["segments"]["thigh"]["com_fraction"]
    data["segments"]["foot"]["mass_fraction"] = -0.1
    data["foot_geometry"]["heel_x_fraction"] = 0.2
    data["contact"]["stiffness"] = "stiff"
    data["contact"]["damping"] = -1.0
    del data["gravity"]
    with pytest.raises(ParameterFileError) as info:
        load_parameters(path=_write(tmp_path, data))
    problems = info.value.problems
    assert problems == [
        "missing key 'segments.thigh.com_fraction'",
        "missing segment 'segments.shank'",
        "'segments.foot.mass_fraction': expected a positive finite number, found -0.1",
        "'foot_geometry.heel_x_fraction' must be less than 'toe_x_fraction' (heel behind toe), "
        "found 0.2 >= 0.08333",
        "'contact.stiffness': expected a positive finite number, found 'stiff'",
        "'contact.damping': expected a non-negative finite number, found -1.0",
        "missing key 'gravity'",
    ]
    assert "has 7 problem(s)" in str(info.value)


def test_missing_sections_and_wrong_types(tmp_path: Path):
    with pytest.raises(ParameterFileError, match="expected a mapping at the top level, found list"):
        load_parameters(path=_write(tmp_path, [1, 2]))
    data = {"segments": {"trunk": 3}, "foot_geometry": [1], "gravity": 9.81}
    with pytest.raises(ParameterFileError) as info:
        load_parameters(path=_write(tmp_path, data))
    assert info.value.problems == [
        "'segments.trunk': expected a mapping, found int",
        "missing segment 'segments.thigh'",
        "missing segment 'segments.shank'",
        "missing segment 'segments.foot'",
        "'foot_geometry': expected a mapping, found list",
        "missing section 'contact'",
    ]
