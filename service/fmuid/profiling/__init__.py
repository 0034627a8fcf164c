"""Profiling: profile likelihoods of a fitted problem, their intervals and labels."""

from fmuid.profiling.engine import profile_problem
from fmuid.profiling.result import ParameterProfile, ProfileResult

__all__ = ["ParameterProfile", "ProfileResult", "profile_problem"]
