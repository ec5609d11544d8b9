"""Models of the EMPS positioning axis (Janot, Gautier, Brunot 2019; data and description in the
benchmark, see notebooks/real_benchmark_emps.ipynb): a mass M driven by the force gtau * nu
against viscous (Fv), Coulomb (Fc) friction and an offset force.

    M d2q/dt2 = tau - Fv dq/dt - Fc sgn(dq/dt) - offset                         (open loop)
    nu = sat(kp kv (qg - q) - kv dq/dt, +-10 V),  tau = gtau nu (+ pulses)       (closed loop)

Usable from the shell: `dcjax fit ... --model notebooks/emps_models.py:EMPSClosedLoop`."""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np

import dcjax
from dcjax.models.dc import smooth_sign

GTAU, KP, KV, V_MAX = 35.15065188, 160.18, 243.45, 10.0  # N/V, 1/s, V/(m/s), V (the benchmark's constants)
V_EPS = 1e-4  # m/s: width of the regularized sgn of the Coulomb friction


class EMPSOpenLoop(dcjax.Model):
    """The inverse model of IDIM-LS: the measured force tau = gtau vir as input, position q
    measured, the velocity v = dq/dt obtained by filtered differentiation."""

    names: ClassVar = ("M", "Fv", "Fc", "offset")
    units: ClassVar = {"M": "kg", "Fv": "N s/m", "Fc": "N", "offset": "N"}
    states: ClassVar = ("q", "v")
    inputs: ClassVar = ("tau",)
    measured: ClassVar = ("q",)
    derivative_of: ClassVar = {"v": "q"}

    def presets(self):
        ranges = {"M": (0.0, 500.0), "Fv": (0.0, 1000.0), "Fc": (0.0, 100.0), "offset": (-50.0, 50.0)}
        return {"default": dcjax.Parameters([dcjax.Parameter(n, min=lo, max=hi) for n, (lo, hi) in ranges.items()])}

    def coefficients(self, p):
        inv_m = 1.0 / p["M"]
        return inv_m, p["Fv"] * inv_m, p["Fc"] * inv_m, p["offset"] * inv_m

    def force(self, u, y):
        return u[0]

    def vector_field(self, c, u, y):
        inv_m, fv, fc, off = c
        q, v = y
        return v, inv_m * self.force(u, y) - fv * v - fc * smooth_sign(v, V_EPS) - off

    def regression(self, y, dy, u):
        v = y["v"]
        return [
            (
                {"M": dy["v"], "Fv": v, "Fc": np.sign(v), "offset": np.ones_like(v)},
                np.asarray(self.force(tuple(u[c] for c in self.inputs), (y["q"], v))),
                "M",
            )
        ]


class EMPSClosedLoop(EMPSOpenLoop):
    """The axis in its P position / P velocity loop: the reference position qg is the input."""

    inputs: ClassVar = ("qg",)

    def force(self, u, y):
        q, v = y
        nu = jnp.clip(KP * KV * (u[0] - q) - KV * v, -V_MAX, V_MAX)
        return GTAU * nu


class EMPSClosedLoopPulses(EMPSClosedLoop):
    """The validation experiment: force pulses (N) added to the drive force."""

    inputs: ClassVar = ("qg", "pulses")

    def force(self, u, y):
        return super().force(u[:1], y) + u[1]
