"""pythonfmu model (FMI 2.0 co-simulation): first-order lag tau y' = K u - y, y(0) = 0.

Each step is the exact solution for an input held over the step, so a constant input gives
y = K u (1 - exp(-t / tau)) to rounding.
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class FirstOrder(Fmi2Slave):
    author = "fmuid tests"
    description = "First-order lag tau y' = K u - y"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.K = 2.0
        self.tau = 0.5
        self.u = 0.0
        self.y = 0.0
        tunable = {"causality": Fmi2Causality.parameter, "variability": Fmi2Variability.tunable}
        self.register_variable(Real("K", description="gain [-]", **tunable))
        self.register_variable(Real("tau", description="time constant [s]", **tunable))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        target = self.K * self.u
        self.y = target + (self.y - target) * math.exp(-step_size / self.tau)
        return True
