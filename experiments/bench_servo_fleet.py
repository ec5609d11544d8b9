"""A joint fit of 476 servo logs (issue: speed at scale, Done-when (a)): dcjax against the peer's
approach, a NumPy simulator of every log at once searched by optuna's CMA-ES, in one process, one
after the other, on the same cores.

Data: 8 setups (pendulum mass x length) of 59-60 logs each (476), 700 samples at 10 ms; goal
trajectories of random steps and sines; simulated by the peer's map below (BAM's "m1" actuator,
written from its description in NumPy, not by dcjax), the position read by a 4096-count encoder
(the MX's). The loss is BAM's: the mean absolute position error, not normalised.

- peer: `optuna.samplers.CmaEsSampler` over the five parameters (log-uniform in the box), each
  trial simulating all 476 logs vectorised over the logs (a Python loop over the 700 samples);
- dcjax: `dcjax.fit(logs, "servo", box, method, observation=Observation(loss=L1(normalize="none"),
  initial={"q": "measured", "dq": 0.0}))`: the built-in `dcjax.Servo`, every log a recording with
  its setup's constants, in one compiled program (the equal-length logs stacked).

Both optima are scored by the peer's own objective (the yardstick), and a fit "reaches the peer's
optimum" where its parameters score within `--tol` (relative) of the peer's best. dcjax's time is
the whole fit (setup, compilation, search); the speed-ups are the peer's time for all its trials
over it ("vs trials") and the peer's time to its first trial within `--tol` of its best over it
("vs to 1e-3"). `defaults`: `dcjax.fit` with no search given. Peak memory: the
process's (both tools; `ru_maxrss`).

    /work/peers/bin/python -m experiments.bench_servo_fleet [--trials 5000] [--logs 476] [--cache DIR]

With `--write DIR` it only writes the logs as CSV files (t, q_goal, q) with their constants in JSON
sidecars, for the command line: `dcjax fit DIR/*.csv --model servo --loss l1 --normalize none
--initial q=measured,dq=0`.

(needs optuna and cmaes: a benchmark venv beside dcjax; `/work/peers` here.)"""

import argparse
import os
import platform
import resource
import time

import numpy as np

BOX = {"kt": (0.5, 5.0), "R": (0.5, 10.0), "armature": (1e-4, 0.05), "friction_base": (1e-3, 0.5), "friction_viscous": (1e-3, 0.3)}
TRUTH = {"kt": 1.6, "R": 2.2, "armature": 0.008, "friction_base": 0.05, "friction_viscous": 0.03}
MASSES, LENGTHS = (0.2, 0.5, 1.0, 1.5), (0.1, 0.2)  # 8 setups
DT, SAMPLES, COUNTS = 0.01, 700, 4096
CONSTANTS = ("kp", "vin", "m", "l", "m_a")  # a log's constants, the columns of `const`


def simulate(p: dict, goal: np.ndarray, const: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """The peer's map, every log at once: goal (N, T), const (N, 5) = kp, vin, m, l, m_a; q (N, T)."""
    kp, vin, m, length, arm = const.T
    bias_gain = -(m + arm / 2.0) * 9.80665 * length
    inertia = m * length**2 + arm * length**2 / 3.0 + p["armature"]
    kt_r, kt2_r = p["kt"] / p["R"], p["kt"] ** 2 / p["R"]
    q, dq = q0.copy(), np.zeros_like(q0)
    out = np.empty_like(goal)
    out[:, 0] = q
    for k in range(goal.shape[1] - 1):
        duty = np.clip(kp * 0.158 * (goal[:, k] - q), -0.9625, 0.9625)
        net = kt_r * vin * duty - kt2_r * dq + bias_gain * np.sin(q)
        stop = inertia / DT * dq + net
        net = net - np.sign(stop) * np.minimum(np.abs(stop), p["friction_base"] + p["friction_viscous"] * np.abs(dq))
        a = net / inertia
        dq = np.clip(dq + a * DT, -100.0, 100.0)
        q = q + dq * DT + 0.5 * a * DT * DT
        out[:, k + 1] = q
    return out


def logs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(goal, const, measured q) of `n` logs over the 8 setups, goals of random steps and sines."""
    rng = np.random.default_rng(seed)
    t = DT * np.arange(SAMPLES)
    setups = [(m, ln) for m in MASSES for ln in LENGTHS]
    goal, const = np.empty((n, SAMPLES)), np.empty((n, 5))
    for i in range(n):
        m, ln = setups[i % len(setups)]
        const[i] = (rng.choice([16.0, 32.0]), rng.choice([12.0, 15.0]), m, ln, 0.05)
        steps = np.repeat(rng.uniform(-1.2, 1.2, 4), SAMPLES // 4 + 1)[:SAMPLES]
        goal[i] = steps + rng.uniform(0.0, 0.5) * np.sin(2 * np.pi * rng.uniform(0.3, 1.5) * t) * (t > 3.5)
    step = 2 * np.pi / COUNTS
    q0 = np.round(rng.uniform(-0.3, 0.3, n) / step) * step  # at rest on an encoder count
    q = simulate(TRUTH, goal, const, q0)
    return goal, const, np.round(q / step) * step


def write_logs(folder: str, goal, const, q) -> None:
    """Every log as `log%03d.csv` (t, q_goal, q) with its constants in `log%03d.json`."""
    import json
    from pathlib import Path

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    t = DT * np.arange(SAMPLES)
    for i in range(len(q)):
        np.savetxt(out / f"log{i:03d}.csv", np.column_stack([t, goal[i], q[i]]), delimiter=",", header="t,q_goal,q", comments="")
        (out / f"log{i:03d}.json").write_text(json.dumps({"constants": dict(zip(CONSTANTS, map(float, const[i])))}))


def objective(p: dict, goal, const, q) -> float:
    """BAM's loss: the mean absolute position error over every sample of every log."""
    return float(np.mean(np.abs(simulate(p, goal, const, q[:, 0]) - q)))


def peer(goal, const, q, trials: int, seed: int) -> tuple[dict, float, list, float]:
    """optuna CMA-ES: (best parameters, best OF, [(seconds, OF) at each improvement], seconds in all)."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.CmaEsSampler(seed=seed))
    best, history, t0 = np.inf, [], time.perf_counter()

    def trial(tr):
        nonlocal best
        p = {k: tr.suggest_float(k, lo, hi, log=True) for k, (lo, hi) in BOX.items()}
        f = objective(p, goal, const, q)
        if f < best:
            best = f
            history.append((time.perf_counter() - t0, f))
        return f

    study.optimize(trial, n_trials=trials)
    return dict(study.best_params), float(study.best_value), history, time.perf_counter() - t0


def dcjax_case(goal, const, q) -> tuple:
    """(recordings, box, observation) of the logs as dcjax fits them: a recording per log with its
    setup's constants, the peer's box, BAM's loss (l1, not normalised), q from its first sample."""
    import dcjax

    t = DT * np.arange(SAMPLES)
    recs = [dcjax.Recording(t=t, channels={"q_goal": goal[i], "q": q[i]}, constants=dict(zip(CONSTANTS, map(float, const[i]))),
                            name=f"log{i}") for i in range(len(q))]  # fmt: skip
    box = dcjax.Parameters([dcjax.Parameter(k, min=lo, max=hi) for k, (lo, hi) in BOX.items()])
    return recs, box, dcjax.Observation(loss=dcjax.L1(normalize="none"), initial={"q": "measured", "dq": 0.0})


def dcjax_fit(goal, const, q, spec: str, seed: int):
    """`spec` METHOD:RUNS:BUDGET, or `defaults`: no search given (`dcjax.fit`'s default)."""
    import dcjax

    recs, box, obs = dcjax_case(goal, const, q)
    search = None
    if spec != "defaults":
        method, runs, budget = spec.split(":")
        search = dcjax.Search(method, runs=int(runs), budget=int(budget), seed=seed)
    t0 = time.perf_counter()
    res = dcjax.fit(recs, "servo", box, search=search, observation=obs)
    return res, time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=476)
    ap.add_argument("--trials", type=int, default=5000)
    ap.add_argument("--tol", type=float, default=1e-3, help="relative: a fit within this of the peer's best OF reaches it")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--cache", metavar="DIR", help="dcjax with the persistent compilation cache in DIR, as the CLI (a second run finds its programs)"
    )
    ap.add_argument("--dcjax", nargs="+", default=["defaults", "cma-es:1:1000", "cma-es:1:2000", "cma-es:4:5000", "de-rand-1-exp:4:20000"],
                    metavar="METHOD:RUNS:BUDGET", help="searches to time; 'defaults': none given (dcjax.fit's default)")  # fmt: skip
    ap.add_argument("--write", metavar="DIR", help="only write the logs as CSV files and sidecars to DIR (for the command line)")
    args = ap.parse_args()
    if args.write:
        write_logs(args.write, *logs(args.logs, args.seed))
        print(f"wrote {args.logs} logs to {args.write}")
        return
    import dcjax

    dcjax.use_host_devices()  # as the CLI starts
    dcjax.use_compiled_loops()
    if args.cache:
        dcjax.use_compilation_cache(args.cache, min_compile_seconds=0.0)
    goal, const, q = logs(args.logs, args.seed)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; {args.logs} logs x {SAMPLES} samples, 8 setups; "
          f"the truth scores {objective(TRUTH, goal, const, q):.6g} (encoder rounding)", flush=True)  # fmt: skip
    t0 = time.perf_counter()
    objective(TRUTH, goal, const, q)
    print(f"peer: one trial (all logs, NumPy) {1e3 * (time.perf_counter() - t0):.1f} ms", flush=True)
    p_best, p_of, history, p_all = peer(goal, const, q, args.trials, args.seed)
    p_at = next(t for t, f in history if f <= p_of * (1 + args.tol))  # the peer's time to its optimum, to the same tolerance
    print(f"peer optuna CMA-ES, {args.trials} trials: best OF {p_of:.6g} (at {history[-1][0]:.1f} s of {p_all:.1f} s), within "
          f"{args.tol:g} of it at {p_at:.1f} s; " + ", ".join(f"{k} {v:.5g}" for k, v in p_best.items()), flush=True)  # fmt: skip
    print(f"{'dcjax':<26} {'wall':>8} {'compile':>8} {'search':>8} {'peer OF of its best':>20} {'reaches':>8} "
          f"{'vs trials':>9} {'vs to 1e-3':>10}")  # fmt: skip
    for spec in args.dcjax:
        res, wall = dcjax_fit(goal, const, q, spec, args.seed)
        if spec == "defaults":
            spec = f"defaults ({res.search.method} x{res.search.runs}, {int(np.max(res.fes)):,} FEs)"
        of = objective(dict(res.best_values), goal, const, q)
        reach = of <= p_of * (1 + args.tol)
        tm = res.timing
        print(f"{spec:<26} {wall:7.1f}s {tm['compile_s']:7.1f}s {tm['run_s'] * max(1, tm.get('batch', 1)):7.1f}s {of:20.6g} "
              f"{'yes' if reach else 'no':>8} {p_all / wall:8.1f}x {p_at / wall:9.1f}x", flush=True)  # fmt: skip
    print(f"peak memory (the process, both tools): {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
