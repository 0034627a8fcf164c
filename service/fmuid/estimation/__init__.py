"""Estimation: the least-squares problem over an FMU, its global start and trust-region fit."""

from fmuid.estimation.optimize import FitOptions, fit_problem
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult
from fmuid.estimation.space import ParameterSpace

__all__ = ["FitOptions", "FitResult", "ParameterSpace", "Problem", "fit_problem"]
