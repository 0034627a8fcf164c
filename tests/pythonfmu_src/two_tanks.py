"""pythonfmu model (FMI 2.0 co-simulation): two tanks in cascade, initial levels as parameters.

tau1 h1' = K u - h1, tau2 h2' = h1 - h2, h1(0) = h1_0, h2(0) = h2_0: the levels at the start
of a record are parameters, as an FMU written for a real plant exposes its initial states. Each
step is integrated by classical Runge-Kutta with sub-steps of at most 0.025 s.
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

SUB_STEP = 0.025


class TwoTanks(Fmi2Slave):
    author = "fmuid tests"
    description = "Two linear tanks in cascade with their initial levels as parameters"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.K = 2.0
        self.tau1 = 0.4
        self.tau2 = 1.5
        self.h1_0 = 0.0
        self.h2_0 = 0.0
        self.u = 0.0
        self.h1 = 0.0
        self.h2 = 0.0
        fixed = {"causality": Fmi2Causality.parameter, "variability": Fmi2Variability.fixed}
        self.register_variable(Real("K", description="gain [m]", **fixed))
        self.register_variable(Real("tau1", description="upper tank time constant [s]", **fixed))
        self.register_variable(Real("tau2", description="lower tank time constant [s]", **fixed))
        self.register_variable(Real("h1_0", description="upper level at the start [m]", **fixed))
        self.register_variable(Real("h2_0", description="lower level at the start [m]", **fixed))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("h1", causality=Fmi2Causality.output))
        self.register_variable(Real("h2", causality=Fmi2Causality.output))

    def exit_initialization_mode(self):
        self.h1 = self.h1_0
        self.h2 = self.h2_0

    def _rate(self, h1, h2):
        return (self.K * self.u - h1) / self.tau1, (h1 - h2) / self.tau2

    def do_step(self, current_time, step_size):
        n = max(1, math.ceil(step_size / SUB_STEP - 1e-9))
        h = step_size / n
        for _ in range(n):
            a1, a2 = self._rate(self.h1, self.h2)
            b1, b2 = self._rate(self.h1 + h / 2 * a1, self.h2 + h / 2 * a2)
            c1, c2 = self._rate(self.h1 + h / 2 * b1, self.h2 + h / 2 * b2)
            d1, d2 = self._rate(self.h1 + h * c1, self.h2 + h * c2)
            self.h1 += h / 6 * (a1 + 2 * b1 + 2 * c1 + d1)
            self.h2 += h / 6 * (a2 + 2 * b2 + 2 * c2 + d2)
        return True
