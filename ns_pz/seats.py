"""Moved to :mod:`ns_pz.learning.seats`; this module keeps earlier imports working."""

from ns_pz.learning.seats import DetectionReward, SeatEnv, single_agent

__all__ = ["DetectionReward", "SeatEnv", "single_agent"]
