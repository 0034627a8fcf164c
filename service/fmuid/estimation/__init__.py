"""Estimation: the least-squares problem over an FMU, its global start and trust-region fit."""

from fmuid.estimation.optimize import FitOptions, fit_problem
from fmuid.estimation.problem import Problem
from fmuid.estimation.result import FitResult

__all__ = ["FitOptions", "FitResult", "Problem", "fit_problem"]
