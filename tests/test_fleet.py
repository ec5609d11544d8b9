"""Fleet identification sharded across devices (issue 6, scale-out)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dcjax
from dcjax import Recording, datasets
from dcjax.io.numpy_simulator import simulate_numpy

PARAM_NAMES = dcjax.DC.names
CODE = """
import json, numpy as np, sys
sys.path.insert(0, {tests!r})
from test_fleet import fleet_recordings
import dcjax
rs = dcjax.fit_each(fleet_recordings(5), params="table4", budget=2100, runs=1, seed=3)
print(json.dumps({{"x": [r.run_params[0].tolist() for r in rs], "of": [r.of for r in rs], "dev": rs[0].timing["devices"]}}))
"""


def fleet_recordings(m, seed=0, n=201):
    """m motors with parameters drawn around SD1 (inside Table 4), 220 V step, 20 ms."""
    truth = np.array([datasets.true_params("SD1")[p] for p in PARAM_NAMES])
    rng = np.random.default_rng(seed)
    x = truth * rng.uniform(0.6, 1.4, (m, 7))
    t = np.arange(n) * 1e-4
    u = np.full(n, 220.0)
    traj = simulate_numpy(x, t, u)
    return [
        Recording(
            t=t, u_a=u, i_a=traj[k, :, 0], omega=traj[k, :, 1], name=f"motor{k}", metadata={"true_params": dict(zip(PARAM_NAMES, x[k]))}
        )
        for k in range(m)
    ]


@pytest.mark.slow
def test_sharded_fleet_equals_single_device():
    outs = {}
    for n in (1, 4):
        env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={n}")
        code = CODE.format(tests=os.path.dirname(__file__))
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
        assert p.returncode == 0, p.stderr
        outs[n] = json.loads(p.stdout.strip().splitlines()[-1])
    assert outs[1]["dev"] == 1 and outs[4]["dev"] == 4
    assert outs[1]["x"] == outs[4]["x"] and outs[1]["of"] == outs[4]["of"]


def test_a_batch_gives_the_same_bits_side_by_side_as_one_after_another(monkeypatch):
    """A batch's recordings run one after another on a CPU (`lax.map`) and side by side elsewhere
    (`vmap`, `dcjax.fitting.runs.side_by_side`): both give every recording the same runs, here
    both on the CPU."""
    from dcjax.fitting import runs

    recs = fleet_recordings(3, seed=2, n=120)
    search = dcjax.Search(runs=2, seed=0, budget=1_400)
    fits = lambda: [r for r in dcjax.fit_each(recs, params="table4", search=search) if isinstance(r, dcjax.FitResult)]
    mapped = fits()
    asked = []
    monkeypatch.setattr(runs, "side_by_side", lambda mesh: asked.append(mesh) or True)
    vmapped = fits()
    assert asked and len(mapped) == len(vmapped) == 3 and mapped[0].timing["batch"] == vmapped[0].timing["batch"] == 3
    for a, b in zip(mapped, vmapped):
        np.testing.assert_array_equal(a.run_params, b.run_params)
        np.testing.assert_array_equal(a.run_of, b.run_of)
        np.testing.assert_array_equal(a.fes, b.fes)


@pytest.mark.slow
def test_fleet_recovers_motors():
    """The fleet is the batch runner: each motor's full result, the bits of a fit of it alone."""
    recs = fleet_recordings(4, seed=1)
    results = dcjax.fit_each(recs, params="table4", search=dcjax.Search(runs=1, seed=0))
    assert all(np.all(r.fes == 140_000) for r in results)
    alone = dcjax.fit(recs[2], params="table4", search=dcjax.Search(runs=1, seed=0))
    np.testing.assert_array_equal(results[2].run_params, alone.run_params)
    assert results[2].success and results[2].nfev == alone.nfev
    for rec, r in zip(recs, results):
        truth = np.array([rec.metadata["true_params"][p] for p in PARAM_NAMES])
        assert r.of <= 1e-15
        np.testing.assert_allclose(r.run_params[0], truth, rtol=1e-6)


@pytest.mark.slow
def test_fleet_across_two_processes_equals_one_process():
    """jax.distributed with two local CPU processes (gloo collectives): the motors are split over
    both processes' devices and every process gets the whole, identical result."""
    import socket

    worker = str(Path(__file__).resolve().parent / "distributed_fleet_worker.py")
    with socket.socket() as s:
        s.bind(("localhost", 0))
        port = str(s.getsockname()[1])
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    procs = [
        subprocess.Popen([sys.executable, worker, str(i), port], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        for i in range(2)
    ]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-2000:] for o in outs]
    results = [json.loads(o[0].strip().splitlines()[-1]) for o in outs]
    alone = subprocess.run([sys.executable, worker, "0", "0", "1"], capture_output=True, text=True, env=env, check=True)
    ref = json.loads(alone.stdout.strip().splitlines()[-1])
    assert results[0]["processes"] == 2 and results[0]["devices"] == 2 and ref["devices"] == 1
    for r in results:
        assert r["of"] == ref["of"] and r["params"] == ref["params"]
