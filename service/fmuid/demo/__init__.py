"""The thesis study (section 3.2.3.1): its constants, the ``fmuid demo`` run and its report.

:mod:`fmuid.demo.thesis` holds the thesis tables, designs and noise levels, :mod:`fmuid.demo.study`
runs the study and :mod:`fmuid.demo.report` writes its page, with the experiment advice of
:mod:`fmuid.demo.advice` and the confidence-interval compilations of
:mod:`fmuid.demo.compilation`.
"""

from fmuid.demo.study import run_demo
from fmuid.demo.thesis import BOUNDS, DESIGNS, NOMINAL, OUTPUTS, SNRS, DatasetRun, Design

__all__ = ["BOUNDS", "DESIGNS", "NOMINAL", "OUTPUTS", "SNRS", "DatasetRun", "Design", "run_demo"]
