"""Preloaded by the forkservers of the local pools only: die with the process that started it.

Importing this module sets ``PR_SET_PDEATHSIG`` in the importing process and exits it at once
when its parent is no longer the pool's owner (:data:`~fmuid.engine.guard.POOL_PARENT_ENV`),
i.e. when the owner died while the server was still starting. Import it nowhere else.
"""

from __future__ import annotations

import os

from fmuid.engine.guard import POOL_PARENT_ENV
from fmuid.processes import die_with_parent

die_with_parent()
if os.environ.get(POOL_PARENT_ENV) != str(os.getppid()):
    os._exit(1)
