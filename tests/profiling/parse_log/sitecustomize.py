"""Log every FmuModel parse with the process id (``tests/profiling/test_parse_once.py``).

Python imports this module at start-up in every process whose ``PYTHONPATH`` holds this folder:
the job process, the forkserver and, through it, every pool worker.
"""

import os

LOG = os.environ.get("FMUID_TEST_PARSE_LOG")
if LOG:
    from fmuid.model.fmu import FmuModel

    _parse = FmuModel.__init__

    def _logged(self, *args, **kwargs):
        _parse(self, *args, **kwargs)
        with open(LOG, "a") as log:
            log.write(f"{os.getpid()} {self.path}\n")

    FmuModel.__init__ = _logged
