"""Which lab markers and force plates stand for which landmarks of the planar model.

The sagittal marker set of GaitAnalysisToolKit's leg2d analysis (Winter's 2-D model), per
side with the side's prefix (``R``/``L``):

==========  ========  =====================================================================
landmark    default   gait2d meaning
==========  ========  =====================================================================
shoulder    ``SHO``   top of the trunk line (hip to shoulder)
hip         ``GTRO``  greater trochanter: the hip joint (gait2d's hip point, ``trunk_x/y``)
knee        ``LEK``   lateral femoral epicondyle: the knee joint
ankle       ``LM``    lateral malleolus: the ankle joint
heel        ``HEE``   heel, at the height of ``toe``
toe         ``MT5``   head of the 5th metatarsal; heel to toe is the foot's sole line
==========  ========  =====================================================================

Each foot stands on its own plate (an instrumented split-belt treadmill): ``FP2`` under the
right foot and ``FP1`` under the left by default, as in the CSU lab's exports.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from colloc.data.columns import SIDES

#: Landmarks of one side, proximal to distal.
LANDMARKS: tuple[str, ...] = ("shoulder", "hip", "knee", "ankle", "heel", "toe")

#: What a lab trial keeps, unfiltered, for the marker smoother
#: (:func:`colloc.lab.trial_from_lab`'s ``track``): the markers the record holds, or the
#: landmarks made of them.
TRACKED_MARKERS: tuple[str, ...] = ("markers", "landmarks")

#: The gait2d segment each landmark moves with (without the side): the hip joint centre is
#: the trunk's origin, the lateral epicondyle sits on the femur, the malleolus on the shank.
LANDMARK_SEGMENTS: dict[str, str] = {
    "shoulder": "trunk",
    "hip": "trunk",
    "knee": "thigh",
    "ankle": "shank",
    "heel": "foot",
    "toe": "foot",
}


def landmark_segment(side: str, landmark: str) -> str:
    """The gait2d segment (:data:`colloc.models.gait2d_markers.SEGMENTS`) a landmark of one
    side moves with: ``trunk``, or ``<side>_thigh``, ``<side>_shank``, ``<side>_foot``."""
    segment = LANDMARK_SEGMENTS[landmark]
    return segment if segment == "trunk" else f"{side}_{segment}"


@dataclass(frozen=True)
class MarkerSet:
    """Names of the markers and plates of an export, by landmark and side.

    Attributes
    ----------
    shoulder, hip, knee, ankle, heel, toe : str
        Marker names without the side prefix.
    prefixes : mapping
        Side (``right``/``left``) -> prefix of its markers.
    plates : mapping
        Side -> name of the force plate under that foot.
    """

    shoulder: str = "SHO"
    hip: str = "GTRO"
    knee: str = "LEK"
    ankle: str = "LM"
    heel: str = "HEE"
    toe: str = "MT5"
    prefixes: Mapping[str, str] = field(default_factory=lambda: {"right": "R", "left": "L"})
    plates: Mapping[str, str] = field(default_factory=lambda: {"right": "FP2", "left": "FP1"})

    def __post_init__(self) -> None:
        problems = [
            f"{mapping}: expected one entry per side {SIDES}, found {sorted(getattr(self, mapping))}"
            for mapping in ("prefixes", "plates")
            if sorted(getattr(self, mapping)) != sorted(SIDES)
        ]
        for mapping in ("prefixes", "plates"):
            values = getattr(self, mapping)
            if problems:
                break
            if any(not isinstance(v, str) or not v.strip() for v in values.values()):
                problems.append(
                    f"{mapping}: expected a non-empty name per side, found {dict(values)}"
                )
            elif len(set(values.values())) < len(SIDES):
                what = "markers" if mapping == "prefixes" else "plate"
                problems.append(
                    f"{mapping}: expected a different one per side, found {dict(values)}: both "
                    f"sides would read the same {what}"
                )
        if problems:
            raise ValueError("; ".join(problems))

    def marker(self, side: str, landmark: str) -> str:
        """The export's name of a landmark's marker on one side (e.g. ``RGTRO``)."""
        return f"{self.prefixes[side]}{getattr(self, landmark)}"

    def side_markers(self, side: str) -> dict[str, str]:
        """Landmark -> marker name, for one side."""
        return {landmark: self.marker(side, landmark) for landmark in LANDMARKS}


#: The CSU lab's names (GaitAnalysisToolKit's exports).
DEFAULT_MARKER_SET = MarkerSet()
