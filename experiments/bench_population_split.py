"""Can one run use two cores? (issue: speed at scale, Done-when (d)). 2,000 generations of SD1's
population objective (70 members, RK4 ND 1, eq. 24), each generation's OFs gathered as a DE's
selection needs them, as one compiled loop: on one host device, and with the members split over
the host's devices (`shard_map`, 70 / devices members each, an `all_gather` of the OFs per
generation: what a population split inside one run costs). Each figure is the median of 7 calls
after a compiling one.

    python -m experiments.bench_population_split
"""

import statistics
import time

import dcjax

dcjax.use_host_devices()
dcjax.use_compiled_loops()

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from jax.sharding import Mesh, PartitionSpec  # noqa: E402

from dcjax.simulation.objectives import population_objective  # noqa: E402

GENERATIONS = 2000


def main():
    sd1 = dcjax.datasets.load("SD1")
    problem = dcjax.make_problem(sd1)
    truth = np.array([dcjax.datasets.true_params("SD1")[n] for n in dcjax.DC().names])
    x0 = jnp.asarray(truth * (1.0 + 0.01 * np.random.default_rng(0).standard_normal((70, 7))))
    devices = jax.devices()

    def generations(of):
        def body(_, x):
            f = of(x)
            return x * (1.0 + 1e-9 * jnp.tanh(f - jnp.mean(f))[:, None])  # every OF reaches every member, as selection does

        return jax.jit(lambda x: jax.lax.fori_loop(0, GENERATIONS, body, x))

    one = generations(lambda x: population_objective(x, problem))
    mesh = Mesh(np.array(devices), ("pop",))

    def split_of(x):
        local = jax.shard_map(
            lambda xs: population_objective(xs, problem),
            mesh=mesh,
            in_specs=PartitionSpec("pop"),
            out_specs=PartitionSpec("pop"),
            check_vma=False,
        )(x)
        return jax.lax.with_sharding_constraint(local, jax.sharding.NamedSharding(mesh, PartitionSpec()))  # gathered

    split = generations(split_of)
    print(f"{len(devices)} host devices; {GENERATIONS} generations of 70 members on SD1, median of 7")
    for label, fn in (("one device", one), (f"members split over {len(devices)} devices", split)):
        jax.block_until_ready(fn(x0))
        ts = []
        for _ in range(7):
            t0 = time.perf_counter()
            jax.block_until_ready(fn(x0))
            ts.append(time.perf_counter() - t0)
        print(f"{label:<34} {statistics.median(ts):.4f} s ({1e6 * statistics.median(ts) / GENERATIONS:.0f} us a generation)", flush=True)


if __name__ == "__main__":
    main()
