"""One process of the two-process fleet test (tests/test_fleet.py): `python THIS PID PORT [N]`;
N = 1 runs alone without jax.distributed (the reference)."""

import json
import sys

import jax

pid, port, n_proc = int(sys.argv[1]), sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 2
if n_proc > 1:
    jax.config.update("jax_cpu_collectives_implementation", "gloo")  # CPU collectives across processes
    jax.distributed.initialize(f"localhost:{port}", num_processes=n_proc, process_id=pid)

import numpy as np  # noqa: E402

import dcjax  # noqa: E402
from dcjax import Recording, datasets  # noqa: E402
from dcjax.io.numpy_simulator import simulate_numpy  # noqa: E402

truth = np.array([datasets.true_params("SD1")[p] for p in dcjax.DC.names])
x = truth * np.random.default_rng(0).uniform(0.8, 1.2, (5, 7))
t = np.arange(101) * 1e-4
u = np.full_like(t, 220.0)
traj = simulate_numpy(x, t, u)
recs = [Recording(t=t, u_a=u, i_a=traj[k, :, 0], omega=traj[k, :, 1]) for k in range(len(x))]
rs = dcjax.fit_each(recs, params="table4", search=dcjax.Search(runs=1, budget=2100, seed=0))
print(
    json.dumps(
        {
            "processes": jax.process_count(),
            "devices": rs[0].timing["devices"],
            "of": [r.of for r in rs],
            "params": [r.run_params[0].tolist() for r in rs],
        }
    )
)
