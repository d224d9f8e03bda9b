"""Walking: periodic gait cycles of the planar gait model."""

from colloc.gait.cycle import WalkingCycle, find_walking_cycle

__all__ = ["WalkingCycle", "find_walking_cycle"]
