"""Walking: periodic gait cycles of the planar gait model."""

from colloc.gait.cycle import find_walking_cycle
from colloc.gait.walking_cycle import WalkingCycle

__all__ = ["WalkingCycle", "find_walking_cycle"]
