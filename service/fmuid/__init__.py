"""fmuid: black-box identifiability of FMU parameters (fits, profile likelihoods, diagnosis).

The stages are plain functions (``fmuid.fit``, ``fmuid.profile``, ``fmuid.diagnose``); the
subpackages ``fmuid.fit`` and ``fmuid.profile`` of the same names hold their machinery and are
imported with ``from fmuid.fit.problem import Problem`` style imports.
"""

from fmuid.stages import fit, profile

__all__ = ["fit", "profile"]
__version__ = "0.1.0"
