"""A laboratory DC drive emulator: recordings as a controlled supply unit's trace would give them
(paper Section 4, Figs. 3 and 5–7, Table 7). The paper's measured MD1–MD4 are not public; this
makes analogues the fitter did not make itself.

- Plant: eq. 6–7 (optionally with effects the fitted model lacks), classic RK4 at `dt_plant`
  (1e-4 s), far finer than any fit on 0.132 s samples.
- Controller, every `dt_control` (1 ms): PI speed loop -> current reference limited to
  +-`i_limit` -> PI current loop -> voltage command limited to [-u_max, u_max]; both integrators
  stop while their output is saturated (anti-windup). The converter ramps linearly from the
  previous command to the new one over the next control period.
- Speed reference: a step to `omega_final`, or a ramp over `t_speed_up` (Table 7).
- Sampling: u, i, w every `dt_sample` (0.132 s). The trace is not synchronized with the
  armature switch-on: the first sample after it comes `first_sample_delay` later (drawn from the
  seed in (0, dt_sample) unless given), and, as in Fig. 6, only the samples after switch-on are
  kept, so the recording starts inside the start-up transient. Optional noise (std as % of range)
  and encoder speed quantization.

Pure Python floats and NumPy's PCG64: the bytes of a regenerated file do not depend on XLA or the
CPU."""

import dataclasses
import math

import numpy as np

from ..errors import ConfigError
from ..models.dc import NAMES as PARAM_NAMES
from .recording import Recording


@dataclasses.dataclass(frozen=True)
class Effects:
    """Unmodelled effects, all off by default.

    - `static_friction`: at standstill the shaft does not turn until cm*i exceeds Tla.
    - `armature_reaction`: cm falls by this fraction at rated current (cm (1 - a |i|/I_rated)).
    - `inductance_drop`: La falls by this fraction at rated current (La (1 - d min(|i|/I_rated, 1))).
    - `noise_u`, `noise_i`, `noise_w`: Gaussian measurement noise, std in % of the signal range
      (u_max, i_limit, omega_final).
    - `encoder_ppr`, `speed_window`: speed measured by counting encoder pulses over a window, so
      it is quantized to 2 pi / (ppr * window); 0 = off."""

    static_friction: bool = False
    armature_reaction: float = 0.0
    inductance_drop: float = 0.0
    noise_u: float = 0.0
    noise_i: float = 0.0
    noise_w: float = 0.0
    encoder_ppr: int = 0
    speed_window: float = 0.01


@dataclasses.dataclass(frozen=True)
class DriveSettings:
    """A controlled drive and its measurement (defaults: the paper's laboratory drive, Table 7)."""

    params: dict
    """The true Ra, La, cm, J, Tla, Tlb, Tlc (load included)."""
    omega_final: float = 126.0
    """The speed reference's final value (rad/s)."""
    t_speed_up: float = 0.0
    """The reference's ramp time (s; 0: a step)."""
    i_limit: float = 11.44
    """The supply's current limit (A)."""
    i_rated: float = 10.4
    """The rated current (A)."""
    u_max: float = 420.0
    """The supply's highest voltage (V)."""
    n_samples: int = 87
    """The samples recorded."""
    dt_sample: float = 0.132
    """The recording's sample time (s)."""
    dt_control: float = 1e-3
    """The controller's period (s)."""
    substeps: int = 10
    """Plant RK4 steps per control period (dt_plant = 1e-4 s)."""
    kp_w: float = 1.0  # A per rad/s
    ki_w: float = 5.0  # A per rad
    kp_i: float = 60.0  # V per A
    ki_i: float = 3000.0  # V per A s
    effects: Effects = Effects()
    seed: int = 0
    first_sample_delay: float | None = None  # s after switch-on; None: drawn from the seed
    name: str = ""

    @property
    def delay(self) -> float:
        """First-sample delay after switch-on, a whole number of control periods >= 1."""
        if self.first_sample_delay is not None:
            d = self.first_sample_delay
        else:
            d = np.random.Generator(np.random.PCG64([self.seed, 1])).uniform(0.0, self.dt_sample)
        return max(1, round(d / self.dt_control)) * self.dt_control

    def __post_init__(self):
        missing = [n for n in PARAM_NAMES if n not in self.params]
        if missing:
            raise ConfigError(f"params missing {missing}")
        if self.params["La"] <= 0 or self.params["J"] <= 0:
            raise ConfigError("La and J must be positive")
        ratio = self.dt_sample / self.dt_control
        if abs(ratio - round(ratio)) > 1e-9 or ratio < 1:
            raise ConfigError("dt_sample must be a whole number of control periods")
        if self.i_limit <= 0 or self.u_max <= 0 or self.n_samples < 3:
            raise ConfigError("i_limit and u_max must be positive, n_samples >= 3")
        if self.first_sample_delay is not None and not 0 <= self.first_sample_delay < self.dt_sample:
            raise ConfigError("first_sample_delay must lie in [0, dt_sample)")


def _plant(s: DriveSettings):
    """The vector field (di/dt, dw/dt) with the switched effects, as plain-float code."""
    p, e = s.params, s.effects
    ra, la, cm, j, tla, tlb, tlc = (float(p[n]) for n in PARAM_NAMES)
    ar, ld, ir = e.armature_reaction, e.inductance_drop, s.i_rated

    def f(u, i, w):
        a = abs(i) / ir
        cm_i = cm * (1.0 - ar * a) if ar else cm
        la_i = la * (1.0 - ld * min(a, 1.0)) if ld else la
        di = (u - i * ra - cm_i * w) / la_i
        torque = cm_i * i - (tla + tlb * w + tlc * w * w)
        if e.static_friction and w <= 0.0 and cm_i * i <= tla:
            torque = 0.0
        return di, torque / j

    return f


def emulate_trace(s: DriveSettings):
    """The fine, noise-free trace at every control instant: (t, u, i, w) arrays, where u is the
    applied voltage (it moves linearly between control instants)."""
    f = _plant(s)
    per_sample = round(s.dt_sample / s.dt_control)
    n_ctrl = (s.n_samples - 1) * per_sample + round(s.delay / s.dt_control)
    h = s.dt_control / s.substeps
    e = s.effects
    i = w = 0.0
    x_w = x_i = 0.0
    v = 0.0  # applied voltage at the start of the period
    ts, us, is_, ws = [], [], [], []
    for k in range(n_ctrl + 1):
        t = k * s.dt_control
        ts.append(t)
        us.append(v)
        is_.append(i)
        ws.append(w)
        if k == n_ctrl:
            break
        # Controller (measures the true state at t).
        w_ref = s.omega_final * min(1.0, t / s.t_speed_up) if s.t_speed_up > 0 else s.omega_final
        err_w = w_ref - w
        i_ref = s.kp_w * err_w + x_w
        i_ref_sat = min(max(i_ref, -s.i_limit), s.i_limit)
        if i_ref == i_ref_sat or (i_ref > i_ref_sat) != (err_w > 0):
            x_w += s.ki_w * err_w * s.dt_control
        err_i = i_ref_sat - i
        c = s.kp_i * err_i + x_i
        c_sat = min(max(c, -s.u_max), s.u_max)
        if c == c_sat or (c > c_sat) != (err_i > 0):
            x_i += s.ki_i * err_i * s.dt_control
        # Plant over the period, voltage ramping from v to the new command (RK4 sub-steps).
        du = (c_sat - v) / s.substeps
        for m in range(s.substeps):
            ua = v + du * m
            um = ua + 0.5 * du
            ub = ua + du
            k1, l1 = f(ua, i, w)
            k2, l2 = f(um, i + 0.5 * h * k1, w + 0.5 * h * l1)
            k3, l3 = f(um, i + 0.5 * h * k2, w + 0.5 * h * l2)
            k4, l4 = f(ub, i + h * k3, w + h * l3)
            i = i + h * (k1 / 6 + k2 / 3 + k3 / 3 + k4 / 6)
            w = w + h * (l1 / 6 + l2 / 3 + l3 / 3 + l4 / 6)
            if e.static_friction and w < 0.0:
                w = 0.0
        v = c_sat
    return np.array(ts), np.array(us), np.array(is_), np.array(ws)


def emulate(s: DriveSettings) -> Recording:
    """The recording a supply unit's trace function would give: `n_samples` samples every
    `dt_sample`, the first `delay` after switch-on (time measured from switch-on), with the
    configured measurement noise and speed quantization."""
    t, u, i, w = emulate_trace(s)
    per_sample = round(s.dt_sample / s.dt_control)
    idx = round(s.delay / s.dt_control) + np.arange(s.n_samples) * per_sample
    t, u, i, w = t[idx], u[idx], i[idx], w[idx]
    e = s.effects
    rng = np.random.Generator(np.random.PCG64(s.seed))
    noise = rng.standard_normal((3, s.n_samples))
    u = u + e.noise_u / 100.0 * s.u_max * noise[0]
    i = i + e.noise_i / 100.0 * s.i_limit * noise[1]
    w = w + e.noise_w / 100.0 * s.omega_final * noise[2]
    if e.encoder_ppr:
        q = 2.0 * math.pi / (e.encoder_ppr * e.speed_window)
        w = np.round(w / q) * q
    meta = {
        "source": "emulated laboratory drive (dcjax.io.emulate), NOT the paper's measurements",
        "true_params": dict(s.params),
        "settings": {k: v for k, v in dataclasses.asdict(s).items() if k not in ("params", "name")},
        "n_points": s.n_samples,
        "first_sample_delay": s.delay,
        "bounds": "table8",
    }
    return Recording(t=t, u_a=u, i_a=i, omega=w, limit=s.i_limit, name=s.name, metadata=meta)


# The emulated drive: one motor for MD1–MD4 (values near the paper's RK results, Table 17).
MOTOR = dict(Ra=5.0, La=0.30, cm=1.37, J=0.045, Tla=0.85, Tlb=2e-4, Tlc=0.0)
LAB_EFFECTS = Effects(
    static_friction=True, armature_reaction=0.03, noise_u=0.3, noise_i=0.5, noise_w=0.1, encoder_ppr=1024, speed_window=0.01
)


def md_settings(name: str) -> DriveSettings:
    """Table 7: MD1 126 1/s, 11.44 A, 87 points; MD2 182 1/s, 11.44 A, 81; MD3 182 1/s, 14.56 A, 65;
    MD4 182 1/s, 14.56 A, ramp over 2 s, load ~7.5e-2 * w, 106 points."""
    table7 = {
        "MD1": dict(omega_final=126.0, i_limit=11.44, t_speed_up=0.0, n_samples=87, load_b=0.0, seed=1),
        "MD2": dict(omega_final=182.0, i_limit=11.44, t_speed_up=0.0, n_samples=81, load_b=0.0, seed=2),
        "MD3": dict(omega_final=182.0, i_limit=14.56, t_speed_up=0.0, n_samples=65, load_b=0.0, seed=3),
        "MD4": dict(omega_final=182.0, i_limit=14.56, t_speed_up=2.0, n_samples=106, load_b=7.5e-2, seed=4),
    }
    key = name.upper()
    if key not in table7:
        raise ConfigError(f"unknown MD set {name!r}; choose from {sorted(table7)}")
    c = dict(table7[key])
    load_b = c.pop("load_b")
    params = dict(MOTOR, Tlb=MOTOR["Tlb"] + load_b)
    return DriveSettings(params=params, effects=LAB_EFFECTS, name=key, **c)  # pyright: ignore[reportArgumentType]
