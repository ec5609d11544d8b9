"""An independent reference simulator for the tests: plain NumPy, no dcjax import.

A model is a NumPy vector field `field(p, u, y) -> dy/dt` (or a discrete map `update(p, u, y, h)
-> y_next`) written out here from its equations, not taken from dcjax. The inputs are the
recorded samples read by the paper's eq. 29 interpolation (linear between samples, held at the
first sample before the start) at every stage time, each input delayed by its own `d`:
u_j(tau - d_j). The ODE is integrated with classic RK4 on `substeps` equal sub-steps per sample
interval, fine enough that the result stands for the exact solution (`converged` checks that);
a sensor offset is added to the reading, not to the state."""

import numpy as np

# -- the models' equations ---------------------------------------------------------------------


def dc_field(p, u, y):
    """The paper's eq. 8-9 as printed: (di/dt, dw/dt)."""
    i, w = y[0], y[1]
    di = (u[0] - p["Ra"] * i - p["cm"] * w) / p["La"]
    dw = (p["cm"] * i - (p["Tla"] + p["Tlb"] * w + p["Tlc"] * w**2)) / p["J"]
    return np.array([di, dw])


def dc_encoder_field(p, u, y):
    """Eq. 8-9 with the shaft angle: (di/dt, dw/dt, dtheta/dt = w)."""
    return np.append(dc_field(p, u, y[:2]), y[1])


def dc_euler_map(p, u, y, h):
    """The paper's motor as its forward-Euler map over one sample interval (eq. 11-12)."""
    return y + h * dc_field(p, u, y)


def dc_encoder_euler_map(p, u, y, h):
    return y + h * dc_encoder_field(p, u, y)


def pmsm_field(p, u, y):
    """A permanent-magnet synchronous motor in the rotor's dq frame, inputs (ud, uq, pole pairs):

    Ld did/dt = ud - Rs id + pp w Lq iq
    Lq diq/dt = uq - Rs iq - pp w (Ld id + psi)
    J dw/dt   = 1.5 pp (psi iq + (Ld - Lq) id iq) - B w - Tl"""
    i_d, i_q, w = y[0], y[1], y[2]
    ud, uq, pp = u[0], u[1], u[2]
    did = (ud - p["Rs"] * i_d + pp * w * p["Lq"] * i_q) / p["Ld"]
    diq = (uq - p["Rs"] * i_q - pp * w * (p["Ld"] * i_d + p["psi"])) / p["Lq"]
    dw = (1.5 * pp * (p["psi"] * i_q + (p["Ld"] - p["Lq"]) * i_d * i_q) - p["B"] * w - p["Tl"]) / p["J"]
    return np.array([did, diq, dw])


def pmsm_encoder_field(p, u, y):
    return np.append(pmsm_field(p, u, y[:3]), y[2])


def dc_sensors(p, states):
    """The paper's motor read by a torque sensor (cm i_a) and a sign-blind speed sensor (|omega|)."""
    return {"torque": p["cm"] * states[:, 0], "speed": np.abs(states[:, 1])}


def spring_drive_field(p, u, y):
    """A DC drive on a torsion spring, (di/dt, dw/dt, dth/dt) with L = 0.05 H and viscous
    friction 0.02 N m s known: L di/dt = u - R i - k w, J dw/dt = k i - 0.02 w - K th."""
    i, w, th = y[0], y[1], y[2]
    return np.array([(u[0] - p["R"] * i - p["k"] * w) / 0.05, (p["k"] * i - 0.02 * w - p["K"] * th) / p["J"], w])


def voice_coil_field(p, u, y):
    """A moving coil on a spring, (di/dt, dv/dt, dx/dt): L di/dt = u - R i - Kf v,
    m dv/dt = Kf i - c v - k x, dx/dt = v."""
    i, v, x = y[0], y[1], y[2]
    return np.array([(u[0] - p["R"] * i - p["Kf"] * v) / p["L"], (p["Kf"] * i - p["c"] * v - p["k"] * x) / p["m"], v])


def heated_block_field(p, u, y):
    """A heated block in a room: C dT/dt = k P - (T - Ta) / Rth."""
    return np.array([(p["k"] * u[0] - (y[0] - p["Ta"]) / p["Rth"]) / p["C"]])


def abs_speed_sensor(states):
    """A pulse counter on a pulley of ratio 0.5 that cannot see the sign: y = |0.5 w|."""
    return np.abs(0.5 * states[:, 1])


def saturating_sensor(states):
    """A speed sensor that saturates at 6 rad/s: y = min(w, 6)."""
    return np.minimum(states[:, 1], 6.0)


def servo_m1_map(p, u, y, h):
    """BAM's "m1" actuator on its pendulum bench (a Dynamixel MX under its firmware's P loop), one
    step of h, written from the BAM paper's description: duty = clip(kp 0.158 (goal - q), +-0.9625),
    motor torque kt vin duty / R - kt^2 dq / R, gravity -(m + m_a/2) 9.80665 l sin q, inertia
    m l^2 + m_a l^2 / 3 + armature; the friction Fc + Fv |dq| opposes the torque that would stop the
    joint within h, never more than it; then dq += a h (clipped to +-100) and q += dq h + a h^2 / 2."""
    q, dq = float(y[0]), float(y[1])
    goal, kp, vin, m, length, arm = (float(v) for v in u)
    duty = min(max(kp * 0.158 * (goal - q), -0.9625), 0.9625)
    motor = p["kt"] * vin * duty / p["R"] - p["kt"] ** 2 * dq / p["R"]
    bias = (m + arm / 2.0) * -9.80665 * length * np.sin(q)
    inertia = m * length**2 + arm * length**2 / 3.0 + p["armature"]
    net = motor + bias
    stop = inertia / h * dq + net
    net += -np.sign(stop) * min(abs(stop), p["friction_base"] + p["friction_viscous"] * abs(dq))
    a = net / inertia
    dq = min(max(dq + a * h, -100.0), 100.0)
    return np.array([q + dq * h + 0.5 * a * h * h, dq])


# -- the simulation ------------------------------------------------------------------------------


def input_at(t, u, tau, delays, held=()):
    """Every input at time `tau`: input j read at tau - d_j by linear interpolation on the
    samples (eq. 29), held at its first (last) sample before (after) the recording; an input in
    `held` (a zero-order hold) is its last sample at or before tau - d_j."""
    out = np.array([np.interp(tau - delays[j], t, u[:, j]) for j in range(u.shape[1])])
    for j in held:
        out[j] = u[min(max(int(np.searchsorted(t, tau - delays[j], side="right")) - 1, 0), len(t) - 1), j]
    return out


def simulate(field, p, t, u, y0, *, substeps=64, delays=None, limit=None, limited=None, clamp=None, held=()):
    """(N, S): the states at the sample instants `t`, RK4 over `substeps` equal sub-steps per
    interval, the inputs `u` (N, M) read at every stage time as `input_at`. `limit`: |y[limited]|
    clamped to it after every sub-step; `clamp`: y -> y applied after every sub-step instead.
    An input in `held` is constant over each sub-step, its value at the sub-step's middle (exact
    where the delayed steps t_j + d fall on sub-step boundaries, as the tests' delays do)."""
    t = np.asarray(t, float)
    u = np.asarray(u, float).reshape(len(t), -1)
    d = np.zeros(u.shape[1]) if delays is None else np.asarray(delays, float)
    y = np.array(y0, float)
    out = np.empty((len(t), len(y)))
    out[0] = y
    for k in range(1, len(t)):
        hs = (t[k] - t[k - 1]) / substeps
        for s in range(substeps):
            tau = t[k - 1] + s * hs
            ua, um, ub = (input_at(t, u, tau + a * hs, d) for a in (0.0, 0.5, 1.0))
            for j in held:
                ua[j] = ub[j] = um[j] = input_at(t, u, tau + 0.5 * hs, d, held)[j]
            k1 = field(p, ua, y)
            k2 = field(p, um, y + 0.5 * hs * k1)
            k3 = field(p, um, y + 0.5 * hs * k2)
            k4 = field(p, ub, y + hs * k3)
            y = y + hs / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            if limit is not None:
                y[limited] = np.clip(y[limited], -limit, limit)
            if clamp is not None:
                y = clamp(y)
        out[k] = y
    return out


def iterate(update, p, t, u, y0, *, delays=None, held=()):
    """(N, S): a discrete-time model's map applied once per interval, y_k = update(p, u(t_{k-1} -
    d), y_{k-1}, t_k - t_{k-1}), the inputs read at the interval's start as `input_at`."""
    t = np.asarray(t, float)
    u = np.asarray(u, float).reshape(len(t), -1)
    d = np.zeros(u.shape[1]) if delays is None else np.asarray(delays, float)
    out = np.empty((len(t), len(y0)))
    out[0] = y = np.array(y0, float)
    for k in range(1, len(t)):
        y = update(p, input_at(t, u, t[k - 1], d, held), y, t[k] - t[k - 1])
        out[k] = y
    return out


def settle(field, p, u0, y0, duration, steps=4000):
    """The state after holding the inputs at `u0` for `duration` s (RK4, `steps` steps): a start
    in steady motion."""
    y = np.array(y0, float)
    u0 = np.asarray(u0, float)
    h = duration / steps
    for _ in range(steps):
        k1 = field(p, u0, y)
        k2 = field(p, u0, y + 0.5 * h * k1)
        k3 = field(p, u0, y + 0.5 * h * k2)
        k4 = field(p, u0, y + h * k3)
        y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


def converged(field, p, t, u, y0, substeps, **kw) -> float:
    """The largest change of any state (relative to its peak) from `substeps` to 2x `substeps`:
    how far the reference is from the exact solution."""
    a = simulate(field, p, t, u, y0, substeps=substeps, **kw)
    b = simulate(field, p, t, u, y0, substeps=2 * substeps, **kw)
    return float(np.max(np.abs(a - b) / np.maximum(np.max(np.abs(b), axis=0), 1e-300)))


def mean_squared_misfit(sim, meas):
    """Eq. 24 from plain arrays: sum over channels of mean((sim - meas)^2) / max|meas|^2."""
    sim, meas = np.asarray(sim, float), np.asarray(meas, float)
    return float(np.sum(np.mean((sim - meas) ** 2, axis=0) / np.max(np.abs(meas), axis=0) ** 2))


# -- process noise and the extended Kalman filter -----------------------------------------------------


def simulate_sde(field, p, t, u, y0, q, rng, *, substeps=64, held=()):
    """(N, S): the states at `t` of dy = f(u, y) dt + dW, W a Wiener process of intensity `q` per
    state (variance q h over a time h), by Euler–Maruyama on `substeps` sub-steps per interval;
    the inputs read as `input_at` at each sub-step's start (an input in `held`: zero-order hold)."""
    t = np.asarray(t, float)
    u = np.asarray(u, float).reshape(len(t), -1)
    d = np.zeros(u.shape[1])
    q = np.asarray(q, float)
    y = np.array(y0, float)
    out = np.empty((len(t), len(y)))
    out[0] = y
    for k in range(1, len(t)):
        hs = (t[k] - t[k - 1]) / substeps
        for s in range(substeps):
            tau = t[k - 1] + s * hs
            y = y + hs * field(p, input_at(t, u, tau, d, held), y) + np.sqrt(q * hs) * rng.standard_normal(len(y))
        out[k] = y
    return out


def rk4_interval(field, p, y, ua, ub, h, substeps):
    """One sample interval of classic RK4 on `substeps` equal sub-steps, the inputs linear from
    `ua` to `ub` over it (eq. 28-29; a held input has ua == ub). Works on complex states."""
    ua, ub = np.asarray(ua, float), np.asarray(ub, float)
    hs = h / substeps
    for s in range(substeps):
        u0 = ua + (ub - ua) * s / substeps
        u1 = ua + (ub - ua) * (s + 1) / substeps
        um = 0.5 * (u0 + u1)
        k1 = field(p, u0, y)
        k2 = field(p, um, y + 0.5 * hs * k1)
        k3 = field(p, um, y + 0.5 * hs * k2)
        k4 = field(p, u1, y + hs * k3)
        y = y + hs / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y


def complex_step_jacobian(f, x):
    """df/dx of a function analytic in x, to rounding: Im f(x + i e_j 1e-30) / 1e-30 per column
    (Squire and Trapp 1998): no truncation error, no cancellation."""
    x = np.asarray(x, float)
    cols = []
    for j in range(x.size):
        xc = x.astype(complex)
        xc[j] += 1e-30j
        cols.append(np.imag(f(xc)) / 1e-30)
    return np.stack(cols, axis=-1)


def extended_kalman_filter(field, output, p, t, u, z, y0, q, r, s0, *, substeps=1, held=()):
    """The EKF written out in NumPy: RK4 intervals as the transition (`rk4_interval`, inputs linear
    between samples, a `held` input at its start), Jacobians by complex step, P predicted as
    F P F' + diag(q) h, the Joseph-form update with R = diag(r^2), from x0 = y0, P0 = diag(s0^2),
    the first sample corrected too. `output(p, u, y)`: the measured outputs. Returns
    (innovations (N, C), S (N, C, C), filtered states (N, S), log-likelihood)."""
    t, u, z = np.asarray(t, float), np.asarray(u, float).reshape(len(t), -1), np.asarray(z, float)
    q, rr = np.asarray(q, float), np.diag(np.asarray(r, float) ** 2)
    x, pk = np.array(y0, float), np.diag(np.asarray(s0, float) ** 2)
    nus, ss, xs, ll = [], [], [], 0.0
    for k in range(len(t)):
        if k:
            ua, ub = u[k - 1].copy(), u[k].copy()
            for j in held:
                ub[j] = ua[j]
            h = t[k] - t[k - 1]
            step = lambda y: rk4_interval(field, p, y, ua, ub, h, substeps)  # noqa: B023
            f = complex_step_jacobian(step, x)
            x = step(x)
            pk = f @ pk @ f.T + np.diag(q * h)
        hk = complex_step_jacobian(lambda y: output(p, u[k], y), x)  # noqa: B023
        nu = z[k] - output(p, u[k], x)
        s = hk @ pk @ hk.T + rr
        gain = pk @ hk.T @ np.linalg.inv(s)
        ikh = np.eye(len(x)) - gain @ hk
        pk = ikh @ pk @ ikh.T + gain @ rr @ gain.T
        x = x + gain @ nu
        ll += -0.5 * (nu @ np.linalg.solve(s, nu) + np.log(np.linalg.det(s)) + len(nu) * np.log(2 * np.pi))
        nus.append(nu), ss.append(s), xs.append(x.copy())
    return np.array(nus), np.array(ss), np.array(xs), ll
