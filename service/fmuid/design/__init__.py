"""Experiment design: which test identifies the parameters, and which tells two models apart."""

from fmuid.design.engine import design
from fmuid.design.result import DesignResult
from fmuid.design.space import Space, load_space, space_from_json

__all__ = ["DesignResult", "Space", "design", "load_space", "space_from_json"]
