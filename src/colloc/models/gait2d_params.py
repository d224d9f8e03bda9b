"""Body-segment and contact parameters of the planar gait model, scaled from Winter's tables.

The fractions live in ``gait2d.yaml`` next to this module; :func:`load_parameters` scales
them to a subject's body mass and height and checks the file, reporting every problem at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from colloc.model.errors import ModelError

#: The parameter file shipped with colloc.
DEFAULT_PARAMETER_FILE: Path = Path(__file__).with_name("gait2d.yaml")

SEGMENT_NAMES: tuple[str, ...] = ("trunk", "thigh", "shank", "foot")
_SEGMENT_KEYS = ("mass_fraction", "length_fraction", "com_fraction", "gyration_fraction")
_FOOT_KEYS = ("ankle_height_fraction", "heel_x_fraction", "toe_x_fraction")
_CONTACT_KEYS = (
    "stiffness",
    "damping",
    "linear_stiffness",
    "friction_coefficient",
    "friction_velocity",
    "smoothing",
)


class ParameterFileError(ModelError):
    """A gait2d parameter file is missing keys or holds unusable values."""

    def __init__(self, problems: list[str], path: Path) -> None:
        super().__init__(problems, what=f"parameter file {path}")


@dataclass(frozen=True)
class SegmentParameters:
    """Mass properties of one rigid segment.

    Attributes
    ----------
    mass : float
        [kg]
    length : float
        Proximal-to-distal length [m].
    com : float
        Distance of the centre of mass from the proximal end along the segment [m].
    inertia : float
        Moment of inertia about the centre of mass, about the axis normal to the plane [kg m^2].
    """

    mass: float
    length: float
    com: float
    inertia: float


@dataclass(frozen=True)
class ContactParameters:
    """Constants of the smooth heel/toe contact model (see ``gait2d.yaml``).

    Attributes
    ----------
    stiffness : float
        Cubic stiffness ``k`` [N/m^3].
    damping : float
        Hunt-Crossley damping ``c`` [s/m].
    linear_stiffness : float
        Weak linear stiffness ``b`` of the ``- b y`` term [N/m].
    friction_coefficient : float
        ``mu`` [-].
    friction_velocity : float
        Slip speed scale ``v_s`` of the tanh friction law [m/s].
    smoothing : float
        ``epsilon`` in ``|y| ~ sqrt(y^2 + epsilon^2)`` [m].
    """

    stiffness: float
    damping: float
    linear_stiffness: float
    friction_coefficient: float
    friction_velocity: float
    smoothing: float


@dataclass(frozen=True)
class Gait2DParameters:
    """All numbers the planar gait model needs, in SI units.

    Attributes
    ----------
    body_mass, height : float
        The subject the segments were scaled to [kg], [m].
    trunk, thigh, shank, foot : SegmentParameters
        Left and right segments share their parameters.
    ankle_height : float
        Height of the ankle joint above the sole [m].
    heel_x, toe_x : float
        Positions of the heel and toe contact points along the foot, relative to the ankle,
        forward positive [m] (the heel is behind the ankle, so ``heel_x < 0``).
    contact : ContactParameters
    gravity : float
        [m/s^2]
    """

    body_mass: float
    height: float
    trunk: SegmentParameters
    thigh: SegmentParameters
    shank: SegmentParameters
    foot: SegmentParameters
    ankle_height: float
    heel_x: float
    toe_x: float
    contact: ContactParameters
    gravity: float

    @property
    def foot_com_x(self) -> float:
        """Foot centre of mass in front of the ankle, along the sole [m]."""
        return self.heel_x + self.foot.com

    @property
    def foot_com_y(self) -> float:
        """Foot centre of mass below the ankle (a positive distance) [m]."""
        return 0.5 * self.ankle_height

    @property
    def total_mass(self) -> float:
        """Trunk plus two legs [kg]."""
        return self.trunk.mass + 2.0 * (self.thigh.mass + self.shank.mass + self.foot.mass)


def load_parameters(
    body_mass: float = 75.0, height: float = 1.80, path: str | Path | None = None
) -> Gait2DParameters:
    """Read the segment fractions and contact constants and scale them to one subject.

    Parameters
    ----------
    body_mass : float
        Body mass [kg], > 0.
    height : float
        Body height [m], > 0.
    path : str or Path, optional
        A YAML file laid out like the shipped ``gait2d.yaml`` (the default).

    Returns
    -------
    Gait2DParameters

    Raises
    ------
    ValueError
        If ``body_mass`` or ``height`` is not a positive finite number.
    FileNotFoundError
        If ``path`` does not exist.
    ParameterFileError
        Listing every missing key and unusable value in the file.
    """
    problems = [
        f"{name}: expected a positive finite number, found {value!r}"
        for name, value in (("body_mass", body_mass), ("height", height))
        if not _is_positive(value)
    ]
    if problems:
        raise ValueError("; ".join(problems))
    file = DEFAULT_PARAMETER_FILE if path is None else Path(path)
    if not file.is_file():
        raise FileNotFoundError(f"path: expected an existing gait2d YAML file, found {file}")
    data = yaml.safe_load(file.read_text(encoding="utf-8"))
    raw = _check(data, file)

    segments = {}
    for name in SEGMENT_NAMES:
        f = raw["segments"][name]
        mass = f["mass_fraction"] * body_mass
        length = f["length_fraction"] * height
        segments[name] = SegmentParameters(
            mass=mass,
            length=length,
            com=f["com_fraction"] * length,
            inertia=mass * (f["gyration_fraction"] * length) ** 2,
        )
    foot = raw["foot_geometry"]
    return Gait2DParameters(
        body_mass=float(body_mass),
        height=float(height),
        ankle_height=foot["ankle_height_fraction"] * height,
        heel_x=foot["heel_x_fraction"] * height,
        toe_x=foot["toe_x_fraction"] * height,
        contact=ContactParameters(**raw["contact"]),
        gravity=raw["gravity"],
        **segments,
    )


def _is_positive(value: Any) -> bool:
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value > 0
    )


def _section(data: dict[str, Any], key: str, problems: list[str]) -> dict[str, Any] | None:
    """The mapping under ``key``; None (and a problem) when it is missing or not a mapping."""
    section = data.get(key)
    if section is None:
        problems.append(f"missing section '{key}'")
        return None
    if not isinstance(section, dict):
        problems.append(f"'{key}': expected a mapping, found {type(section).__name__}")
        return None
    return section


def _numbers(
    section: dict[str, Any] | None,
    where: str,
    keys: tuple[str, ...],
    problems: list[str],
    *,
    signed: tuple[str, ...] = (),
    nonnegative: tuple[str, ...] = (),
) -> dict[str, float]:
    values: dict[str, float] = {}
    if section is None:
        return values
    for key in keys:
        name = f"{where}.{key}" if where else key
        if key not in section:
            problems.append(f"missing key '{name}'")
            continue
        value = section[key]
        is_number = isinstance(value, int | float) and not isinstance(value, bool)
        if key in signed:
            ok = is_number and math.isfinite(value)
            expected = "a finite number"
        elif key in nonnegative:
            ok = is_number and math.isfinite(value) and value >= 0
            expected = "a non-negative finite number"
        else:
            ok = _is_positive(value)
            expected = "a positive finite number"
        if not ok:
            problems.append(f"'{name}': expected {expected}, found {value!r}")
            continue
        values[key] = float(value)
    return values


def _check(data: Any, file: Path) -> dict[str, Any]:
    """Validate the YAML content; collect every problem before raising."""
    problems: list[str] = []
    if not isinstance(data, dict):
        raise ParameterFileError(
            [f"expected a mapping at the top level, found {type(data).__name__}"], file
        )
    segments_in = _section(data, "segments", problems) or {}
    segments = {}
    for name in SEGMENT_NAMES:
        if name not in segments_in:
            problems.append(f"missing segment 'segments.{name}'")
            continue
        seg = segments_in[name]
        if not isinstance(seg, dict):
            problems.append(f"'segments.{name}': expected a mapping, found {type(seg).__name__}")
            continue
        segments[name] = _numbers(seg, f"segments.{name}", _SEGMENT_KEYS, problems)
    foot = _numbers(
        _section(data, "foot_geometry", problems),
        "foot_geometry",
        _FOOT_KEYS,
        problems,
        signed=("heel_x_fraction",),
    )
    if "heel_x_fraction" in foot and "toe_x_fraction" in foot:
        if not foot["heel_x_fraction"] < foot["toe_x_fraction"]:
            problems.append(
                "'foot_geometry.heel_x_fraction' must be less than 'toe_x_fraction' "
                f"(heel behind toe), found {foot['heel_x_fraction']} >= {foot['toe_x_fraction']}"
            )
    contact = _numbers(
        _section(data, "contact", problems),
        "contact",
        _CONTACT_KEYS,
        problems,
        nonnegative=("damping", "linear_stiffness", "friction_coefficient"),
    )
    gravity = _numbers(data, "", ("gravity",), problems)
    if problems:
        raise ParameterFileError(problems, file)
    return {
        "segments": segments,
        "foot_geometry": foot,
        "contact": contact,
        "gravity": gravity["gravity"],
    }
