"""A forced mass-spring-damper, in plain numpy, as a vectorid model of your own.

    m x'' + c x' + k x = F0 sin(2 pi f t)

Parameters m (kg), c (N s/m), k (N/m); states x (m), v (m/s); outputs x (m) and the
acceleration a (m/s^2) an accelerometer on the mass reads. The force is known (the shaker's
setting): model options force_amplitude (N) and force_frequency (Hz).
"""

import numpy as np

from vectorid.models import Channel, Parameter, SystemModel


class MassSpringDamper(SystemModel):
    name = "mass-spring-damper"
    parameters = (
        Parameter("m", 1.0, 0.8, 1.6, "kg", "mass"),
        Parameter("c", 1.0, 0.2, 2.0, "N*s/m", "damping coefficient"),
        Parameter("k", 45.0, 30.0, 60.0, "N/m", "spring stiffness"),
    )
    states = (
        Channel("x", "m", "displacement of the mass", default=0.0),
        Channel("v", "m/s", "velocity of the mass", default=0.0),
    )
    outputs = (
        Channel("x", "m", "displacement of the mass"),
        Channel("a", "m/s^2", "acceleration of the mass"),
    )

    def __init__(self, force_amplitude=2.0, force_frequency=1.5):
        self.force_amplitude = float(force_amplitude)  # N
        self.force_frequency = float(force_frequency)  # Hz

    def acceleration(self, t, x, p):
        """m/s^2 of every trial: x (n, 2) states, p (n, 3) parameters."""
        m, c, k = p[:, 0], p[:, 1], p[:, 2]
        force = self.force_amplitude * np.sin(2 * np.pi * self.force_frequency * t)
        return (force - c * x[:, 1] - k * x[:, 0]) / m

    def rhs(self, t, x, p):
        """d(x, v)/dt of the whole batch, (n, 2)."""
        return np.column_stack([x[:, 1], self.acceleration(t, x, p)])

    def output(self, t, x, p):
        """The outputs (x, a) of the whole batch, (n, 2)."""
        return np.column_stack([x[:, 0], self.acceleration(t, x, p)])
