"""A position-controlled servo driving a pendulum, as a discrete-time map: the "m1" actuator model
of BAM (Better Actuator Models, Duclusaud & Passault 2025; a Dynamixel MX-64/106 under its
firmware's P loop), a built-in beyond the paper's DC motor (`dcjax.models.Servo`, `--model servo`).

Per sample interval dt, from the position q and velocity dq:

    V     = vin clip(kp g_e (q_goal - q), -d_max, d_max)          firmware P loop, duty clipped
    tau_m = kt V / R - kt^2 dq / R                                 torque less the back-EMF
    tau_g = -(m + m_a / 2) g l sin q                               the pendulum's gravity
    I     = m l^2 + m_a l^2 / 3 + armature                         inertia at the joint
    tau_s = (I / dt) dq + tau_m + tau_g                            the torque that stops it in dt
    tau_f = -sgn(tau_s) min(|tau_s|, Fc + Fv |dq|)                 Coulomb + viscous, sticking
    a     = (tau_m + tau_g + tau_f) / I
    dq'   = clip(dq + a dt, -100, 100),   q' = q + dq' dt + a dt^2 / 2

Parameters kt (Nm/A), R (Ohm), armature (kg m^2), friction_base Fc (Nm), friction_viscous Fv
(Nm s/rad), all positive. Inputs: the goal position q_goal (rad, logged) and per recording the
firmware gain kp, the supply voltage vin (V) and the pendulum's mass m (kg), length l (m) and arm
mass m_a (kg) (`Recording(constants=...)`, a sidecar's "constants", the command line's constants).
The firmware's error gain g_e (0.158 duty per firmware unit and rad) and largest duty d_max
(0.9625) are the MX's, fields of the model (`Servo(error_gain=..., max_pwm=...)`). The position
is measured; the velocity is its derivative (`derivative_of`)."""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .base import DiscreteModel
from .parameters import Parameter, Parameters
from .trig import sin

NAMES = ("kt", "R", "armature", "friction_base", "friction_viscous")
GRAVITY = 9.80665  # m/s^2
MAX_SPEED = 100.0  # rad/s: the map's velocity clip


class Servo(DiscreteModel):
    """Parameters kt, R, armature, friction_base, friction_viscous; inputs q_goal, kp, vin, m, l,
    m_a; states q, dq, q measured (module docstring)."""

    error_gain: float = eqx.field(static=True, default=0.158)
    max_pwm: float = eqx.field(static=True, default=0.9625)

    names: ClassVar[tuple[str, ...]] = NAMES
    units: ClassVar[dict[str, str]] = {
        "kt": "Nm/A",
        "R": "Ohm",
        "armature": "kg m^2",
        "friction_base": "Nm",
        "friction_viscous": "Nm s/rad",
    }
    states: ClassVar[tuple[str, ...]] = ("q", "dq")
    inputs: ClassVar[tuple[str, ...]] = ("q_goal", "kp", "vin", "m", "l", "m_a")
    measured: ClassVar[tuple[str, ...] | None] = ("q",)
    derivative_of: ClassVar[dict[str, str]] = {"dq": "q"}
    follows: ClassVar[dict[str, str]] = {"q": "q_goal"}
    positive: ClassVar[tuple[str, ...]] = NAMES
    required: ClassVar[tuple[str, ...]] = ("kt", "R")
    quantities: ClassVar[dict[str, str]] = {"q_goal": "angle", "q": "angle", "dq": "angular speed", "vin": "voltage"}

    @property
    def name(self) -> str:
        return "servo"

    def presets(self):
        """`mx`: BAM's ranges for an MX-64/106 (kt, R, armature) and 0..1 for the frictions."""
        ranges = {"kt": (1.0, 3.0), "R": (1.0, 5.0), "armature": (1e-3, 5e-2), "friction_base": (0.0, 1.0), "friction_viscous": (0.0, 1.0)}
        return {
            "mx": Parameters(
                [Parameter(n, min=a, max=b, unit=self.units[n], precision=1e-9, positive=True) for n, (a, b) in ranges.items()]
            )
        }

    def update(self, c, u, y, dt):
        q, dq = y
        goal, kp, vin, m, length, arm = u
        volts = vin * jnp.clip(kp * self.error_gain * (goal - q), -self.max_pwm, self.max_pwm)
        per_volt = c["kt"] / c["R"]  # a coefficient, not a division of every sample (4 -> 2 divisions a step)
        motor = per_volt * volts - per_volt * c["kt"] * dq
        gravity = -(m + arm / 2.0) * GRAVITY * length * sin(q)  # vectorises on the CPU (`trig`)
        inertia = (m + arm / 3.0) * length**2 + c["armature"]
        stop = inertia / dt * dq + motor + gravity
        friction = -jnp.sign(stop) * jnp.minimum(jnp.abs(stop), c["friction_base"] + c["friction_viscous"] * jnp.abs(dq))
        acc = (motor + gravity + friction) / inertia
        dq_next = jnp.clip(dq + acc * dt, -MAX_SPEED, MAX_SPEED)
        return q + dq_next * dt + 0.5 * acc * dt * dt, dq_next

    def derived(self, p):
        """The motor's stall torque per volt kt/R and its back-EMF damping kt^2/R."""
        r = float(p["R"])
        if not r > 0:
            return {}
        return {"torque per volt kt/R": (float(p["kt"]) / r, "Nm/V"), "back-EMF damping kt^2/R": (float(p["kt"]) ** 2 / r, "Nm s/rad")}
