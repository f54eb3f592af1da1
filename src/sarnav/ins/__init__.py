"""Strapdown INS in the NED tangent frame, batched over runs."""

from sarnav.ins.state import NavState
from sarnav.ins.strapdown import MechanizationHistory, check_sample_times, mechanize

__all__ = ["NavState", "mechanize", "check_sample_times", "MechanizationHistory"]
