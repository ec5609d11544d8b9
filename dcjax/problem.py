"""A recording prepared for simulation: the sample grid, the input voltage and the scaled
targets of the objective (paper eq. 24, 27), plus the integration settings (eq. 28–29)."""

from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .recording import Recording

Integrator = Literal["euler", "rk4"]
INTEGRATORS = ("euler", "rk4")


class Problem(eqx.Module):
    """Everything `simulate` and `objective` need, as arrays.

    Sample k = 0 is the initial state; interval k (k = 1..N-1) integrates from t[k-1] to
    t[k] with step h[k-1] = t[k] - t[k-1], split into `nd` equal sub-steps (eq. 28) with the
    voltage interpolated linearly between u[k-1] and u[k] (eq. 29)."""

    h: Float[Array, " n-1"]
    u_start: Float[Array, " n-1"]
    u_end: Float[Array, " n-1"]
    i_meas: Float[Array, " n"]
    w_meas: Float[Array, " n"]
    i0: Float[Array, ""]
    w0: Float[Array, ""]
    i_limit: Float[Array, ""] | None
    ci: Float[Array, ""]  # w1 / (N * max|i|^2)
    cw: Float[Array, ""]  # w2 / (N * max|w|^2)
    integrator: str = eqx.field(static=True, default="rk4")
    nd: int = eqx.field(static=True, default=1)
    unroll: int = eqx.field(static=True, default=1)

    @property
    def n(self) -> int:
        return self.i_meas.shape[0]


def make_problem(
    recording: Recording,
    integrator: Integrator = "rk4",
    nd: int = 1,
    weights: tuple[float, float] = (1.0, 1.0),
    voltage: float | None = None,
    i0: float | None = None,
    w0: float | None = None,
    i_limit: float | None = None,
    unroll: int = 1,
) -> Problem:
    """Prepare `recording` for `simulate`/`objective`.

    - `integrator`: `"euler"` (eq. 11–12) or `"rk4"` (eq. 14–23).
    - `nd`: sub-steps per sample interval (eq. 28); the voltage is interpolated (eq. 29).
    - `weights`: (w1, w2) of eq. 27. The paper's eq. 24 is `(1, 1)`, the default, so OF values
      compare directly with Tables 5, 9–16; eq. 27 uses w1 + w2 = 1 (e.g. (0.5, 0.5) is half
      of eq. 24).
    - `voltage`: a constant armature voltage (step response) instead of the recorded u_a.
    - `i0, w0`: initial state; default the recording's first sample.
    - `i_limit`: supply current limit (A); default the recording's `i_a_limit` (None: no limit).
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    if not isinstance(nd, (int, np.integer)) or isinstance(nd, bool) or nd < 1:
        raise ValueError(f"nd must be a positive integer, got {nd!r}")
    if not isinstance(unroll, (int, np.integer)) or unroll < 1:
        raise ValueError(f"unroll must be a positive integer, got {unroll!r}")
    w1, w2 = (float(x) for x in weights)
    if not (np.isfinite(w1) and np.isfinite(w2)) or w1 < 0 or w2 < 0 or w1 + w2 == 0:
        raise ValueError(f"weights must be non-negative, finite and not both zero, got {weights!r}")
    t = recording.t
    u = recording.u_a if voltage is None else np.full_like(t, float(voltage))
    if not np.all(np.isfinite(u)):
        raise ValueError("voltage must be finite")
    limit = recording.i_a_limit if i_limit is None else float(i_limit)
    if limit is not None and not limit > 0:
        raise ValueError(f"current limit must be positive, got {limit}")
    n = t.shape[0]
    i_max = np.max(np.abs(recording.i_a))
    w_max = np.max(np.abs(recording.omega))
    f64 = lambda x: jnp.asarray(x, dtype=jnp.float64)  # noqa: E731
    return Problem(
        h=f64(np.diff(t)),
        u_start=f64(u[:-1]),
        u_end=f64(u[1:]),
        i_meas=f64(recording.i_a),
        w_meas=f64(recording.omega),
        i0=f64(recording.i_a[0] if i0 is None else i0),
        w0=f64(recording.omega[0] if w0 is None else w0),
        i_limit=None if limit is None else f64(limit),
        ci=f64(w1 / (n * i_max**2)),
        cw=f64(w2 / (n * w_max**2)),
        integrator=integrator,
        nd=int(nd),
        unroll=int(unroll),
    )
