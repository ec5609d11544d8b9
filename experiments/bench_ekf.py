"""The prediction-error objective's cost (issue 56, item 5): per population member and evaluation,
dcjax's EKF (`Problem(predictor=EKF)`: the innovations' -log L / N) against dcjax's open-loop
simulation objective on the same record, and against dynamax's jitted `extended_kalman_filter`
(vmapped over the population; what a JAX user would pick) on the same model: the paper's DC motor,
RK4 over one sample interval with the voltage held (zero-order hold), both states measured,
process noise on omega. Same run, same machine, one device, `use_compiled_loops()`.

    python -m experiments.bench_ekf [--samples 1500] [--members 64] [--repeat 30]
"""

import argparse
import platform
import time

import dcjax

dcjax.use_compiled_loops()

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from dcjax.io import datasets  # noqa: E402
from dcjax.simulation.kalman import kalman_filter  # noqa: E402
from dcjax.simulation.objectives import objective  # noqa: E402
from dcjax.simulation.predictors import EKF  # noqa: E402
from dcjax.simulation.problem import make_problem  # noqa: E402

Q_OMEGA = 4e4  # (rad/s)^2/s


def record(n: int, seed: int = 0) -> tuple[dcjax.Recording, np.ndarray]:
    """SD1's motor under a voltage stepped every 50 samples, 0.5 % sensor noise (the cost does not
    depend on the data's realism)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-4
    u = np.repeat(rng.uniform(40.0, 220.0, n // 50 + 1), 50)[:n]
    rec = dcjax.Recording(t=t, u_a=u)
    y = np.asarray(dcjax.simulate(datasets.true_params("SD1"), make_problem(rec, hold={"u_a": "zoh"}, measured=False)))
    r = 0.005 * np.abs(y).max(axis=0)
    z = y + r * rng.standard_normal(y.shape)
    return dcjax.Recording(t=t, u_a=u, i_a=z[:, 0], omega=z[:, 1], name="bench"), r


def dynamax_loglik(theta, u, z, h, r, q):
    """dynamax's EKF log-likelihood of the same model, written as a JAX user would."""
    from dynamax.nonlinear_gaussian_ssm import ParamsNLGSSM, extended_kalman_filter

    ra, la, cm, j, tla, tlb, tlc = theta

    def field(x, v):
        i, w = x[0], x[1]
        return jnp.stack([(v - ra * i - cm * w) / la, (cm * i - tla - tlb * w - tlc * w * w) / j])

    def step(x, v):  # RK4 over one interval, the input held
        k1 = field(x, v[0])
        k2 = field(x + 0.5 * h * k1, v[0])
        k3 = field(x + 0.5 * h * k2, v[0])
        k4 = field(x + h * k3, v[0])
        return x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)

    params = ParamsNLGSSM(
        initial_mean=jnp.zeros(2),
        initial_covariance=jnp.diag(jnp.array([1e-12, 1e-12])),
        dynamics_function=step,
        dynamics_covariance=jnp.diag(jnp.array([0.0, q * h])),
        emission_function=lambda x, v: x,
        emission_covariance=jnp.diag(r**2),
    )
    held = jnp.concatenate([u[:1], u[:-1]])  # dynamax's step t-1 -> t reads u_t: u_{t-1} there is the held sample
    return extended_kalman_filter(params, z, inputs=held, output_fields=[]).marginal_loglik


def interleaved(calls: dict, repeat: int, members: int) -> dict[str, tuple[float, float, float]]:
    """{name: (compile s, min, median us per member and evaluation)}: each call's first run
    timed as its compile, then `repeat` rounds that run every call once in turn, so that the
    machine's drift falls on each alike (the simulation alone, timed in a row, varied 6-10 us)."""
    out, times = {}, {name: [] for name in calls}
    for name, (fn, args) in calls.items():
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        out[name] = time.perf_counter() - t0
    for _ in range(repeat):
        for name, (fn, args) in calls.items():
            t0 = time.perf_counter()
            jax.block_until_ready(fn(*args))
            times[name].append(time.perf_counter() - t0)
    return {n: (out[n], min(t) / members * 1e6, float(np.median(t)) / members * 1e6) for n, t in times.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=1500)
    ap.add_argument("--members", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=30)
    a = ap.parse_args()
    rec, r = record(a.samples)
    truth = datasets.true_params("SD1")
    model = dcjax.DC()
    ekf = EKF.of(model, process={"omega": Q_OMEGA}, measurement={"i_a": r[0], "omega": r[1]}, initial={"i_a": 1e-6, "omega": 1e-6})
    sim = make_problem(rec, hold={"u_a": "zoh"})
    pe = make_problem(rec, hold={"u_a": "zoh"}, predictor=ekf, initial={"i_a": 0.0, "omega": 0.0})  # dynamax starts at 0 too
    x = np.array([truth[n] for n in model.names])
    pop = jnp.asarray(x * (1 + 0.01 * np.random.default_rng(0).standard_normal((a.members, len(x)))))
    f_sim, f_pe = jax.jit(objective), jax.jit(objective)
    u = jnp.asarray(rec["u_a"])[:, None]
    z = jnp.column_stack([rec["i_a"], rec["omega"]])
    h = float(rec.t[1] - rec.t[0])
    dyn = jax.jit(jax.vmap(lambda th: dynamax_loglik(th, u, z, h, jnp.asarray(r), Q_OMEGA)))
    calls = {"dcjax simulation (output error)": (f_sim, (pop, sim)), "dcjax EKF (prediction error)": (f_pe, (pop, pe))}
    rows = interleaved(calls, a.repeat, a.members)  # dynamax's long calls apart: after one, the simulation ran 2x slower
    rows |= interleaved({"dynamax extended_kalman_filter (vmapped)": (dyn, (pop,))}, a.repeat, a.members)
    ll_dcjax = float(kalman_filter(x, pe, ekf).log_likelihood)
    ll_dynamax = float(dynamax_loglik(jnp.asarray(x), u, z, h, jnp.asarray(r), Q_OMEGA))
    print(f"{platform.processor() or platform.machine()}, {jax.device_count()} device(s), jax {jax.__version__}; "
          f"{a.samples} samples, {a.members} members, {a.repeat} interleaved rounds (min / median)")  # fmt: skip
    base = rows["dcjax simulation (output error)"]
    for name, (c, lo, mid) in rows.items():
        print(
            f"  {name:<42} compile {c:5.2f} s   {lo:7.1f} / {mid:7.1f} us/member   {lo / base[1]:6.1f} / {mid / base[2]:6.1f} x the simulation"
        )
    dyn_row, ekf_row = rows["dynamax extended_kalman_filter (vmapped)"], rows["dcjax EKF (prediction error)"]
    print(
        f"  dcjax EKF is {dyn_row[1] / ekf_row[1]:.1f}x dynamax's speed (min; median {dyn_row[2] / ekf_row[2]:.1f}x); "
        f"log L at the truth: dcjax {ll_dcjax:.6f}, dynamax {ll_dynamax:.6f}"
    )


if __name__ == "__main__":
    main()
