"""fmuid: black-box identifiability of FMU parameters (fits, profile likelihoods, diagnosis).

The stages are plain functions: ``fmuid.fit``, ``fmuid.profile``, ``fmuid.diagnose`` and
``fmuid.design``. The
subpackages of the same names hold their machinery; import from them with
``from fmuid.fit.problem import Problem`` style imports.
"""

from fmuid.design import design
from fmuid.diagnose import diagnose
from fmuid.stages import fit, profile

__all__ = ["design", "diagnose", "fit", "profile"]
__version__ = "0.1.0"
