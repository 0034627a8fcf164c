"""Experiment design: which test identifies the parameters, and which tells two models apart."""

from fmuid.experiment_design.engine import design
from fmuid.experiment_design.result import DesignResult
from fmuid.experiment_design.space import Space, load_space, space_from_json

__all__ = ["DesignResult", "Space", "design", "load_space", "space_from_json"]
