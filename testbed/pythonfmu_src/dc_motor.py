"""pythonfmu model (FMI 2.0 co-simulation) of a DC motor: voltage in, current and speed out.

    L di/dt = V - R i - K w        J dw/dt = K i - b w

V [V] armature voltage, i [A] armature current, w [rad/s] shaft speed; R [Ohm], L [H], K [N m/A
= V s/rad], J [kg m^2], b [N m s]. Each step is the exact solution of the linear equations for
the input held over the step (the step's transition matrix is cached per parameters and step).
pythonfmu declares no units: they are in the descriptions.
"""

import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real

PARAMETERS = {
    "R": (1.0, "armature resistance [Ohm]"),
    "L": (0.005, "armature inductance [H]"),
    "K": (0.05, "torque and back-emf constant [N m/A]"),
    "J": (0.001, "rotor inertia [kg m^2]"),
    "b": (0.001, "viscous friction [N m s]"),
}


def expm2(a11, a12, a21, a22):
    """exp of a real 2x2 matrix (Cayley-Hamilton, real or complex eigenvalues)."""
    half = 0.5 * (a11 + a22)
    d = (0.5 * (a11 - a22)) ** 2 + a12 * a21
    e = math.exp(half)
    if d > 1e-14:
        s = math.sqrt(d)
        c, g = math.cosh(s), math.sinh(s) / s
    elif d < -1e-14:
        s = math.sqrt(-d)
        c, g = math.cos(s), math.sin(s) / s
    else:
        c, g = 1.0 + d / 2, 1.0 + d / 6
    return (
        e * (c + g * (a11 - half)),
        e * g * a12,
        e * g * a21,
        e * (c + g * (a22 - half)),
    )


class DcMotor(Fmi2Slave):
    author = "a user of fmuid"
    description = "DC motor: armature voltage V [V] -> current i [A], speed w [rad/s]"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        tunable = {"causality": Fmi2Causality.parameter, "variability": Fmi2Variability.tunable}
        for name, (value, text) in PARAMETERS.items():
            setattr(self, name, value)
            self.register_variable(Real(name, description=text, **tunable))
        self.V = 0.0
        self.i = 0.0
        self.w = 0.0
        self.register_variable(
            Real("V", causality=Fmi2Causality.input, description="armature voltage [V]")
        )
        self.register_variable(
            Real("i", causality=Fmi2Causality.output, description="armature current [A]")
        )
        self.register_variable(
            Real("w", causality=Fmi2Causality.output, description="shaft speed [rad/s]")
        )
        self._key = None
        self._step = None

    def _matrices(self, h):
        """Transition (phi) and input (gamma) of one held-input step of length h."""
        key = (self.R, self.L, self.K, self.J, self.b, h)
        if key != self._key:
            a11, a12 = -self.R / self.L, -self.K / self.L
            a21, a22 = self.K / self.J, -self.b / self.J
            phi = expm2(a11 * h, a12 * h, a21 * h, a22 * h)
            det = a11 * a22 - a12 * a21
            # gamma = A^-1 (phi - I) B with B = (1/L, 0)
            x1, x2 = (phi[0] - 1.0) / self.L, phi[2] / self.L
            gamma = ((a22 * x1 - a12 * x2) / det, (-a21 * x1 + a11 * x2) / det)
            self._key, self._step = key, (phi, gamma)
        return self._step

    def do_step(self, current_time, step_size):
        (p11, p12, p21, p22), (g1, g2) = self._matrices(step_size)
        i, w = self.i, self.w
        self.i = p11 * i + p12 * w + g1 * self.V
        self.w = p21 * i + p22 * w + g2 * self.V
        return True
