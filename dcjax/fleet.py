"""Identify a fleet of motors in one compiled call, sharded across devices with `jax.sharding`.

Recordings of equal length are stacked into one batched `Problem` pytree; the search is `vmap`ped
over motors (and runs per motor) and the motor axis is sharded over every device JAX sees
(`Mesh` + `NamedSharding`). The same code runs on one CPU, on several XLA host devices
(`--xla_force_host_platform_device_count`), on a GPU, and across hosts after
`jax.distributed.initialize()` (arrays are built with `jax.make_array_from_callback`, which every
process calls with the same host data)."""

import dataclasses
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .bounds import resolve_bounds
from .models import get_model
from .objectives import objective
from .problem import make_problem
from .recording import Recording
from .runner import fold_keys, mesh_of, padded_size, shard
from .space import make_space
from .strategies import make_strategy, run


@dataclasses.dataclass
class FleetResult:
    params: np.ndarray  # (M, P) best of each motor's runs
    of: np.ndarray  # (M,)
    fes: np.ndarray  # (M, runs)
    timing: dict
    settings: dict
    names: tuple[str, ...] = ()

    def to_dicts(self) -> list[dict[str, float]]:
        return [dict(zip(self.names, map(float, x))) for x in self.params]


def _to_host(a: jax.Array) -> np.ndarray:
    """The whole array on this host: gathered from every process after `jax.distributed`."""
    if jax.process_count() > 1 and not a.is_fully_addressable:
        from jax.experimental import multihost_utils

        return np.asarray(multihost_utils.process_allgather(a, tiled=True))
    return np.asarray(jax.device_get(a))


def identify_fleet(
    recordings: list[Recording],
    method: str = "de-rand-1-exp",
    integrator: str = "rk4",
    nd: int = 1,
    weights: tuple[float, ...] | None = None,
    bounds=None,
    runs: int = 1,
    budget: int = 140_000,
    seed: int = 0,
    pop_size: int = 70,
    devices: list | None = None,
    model=None,
    fixed: dict[str, float] | None = None,
) -> FleetResult:
    """One identification per recording (motor), all in one sharded call. Motor m, run r uses
    key fold_in(fold_in(PRNGKey(seed), m), r), so results do not depend on the device count."""
    if not recordings or not all(isinstance(r, Recording) for r in recordings):
        raise ValueError("recordings must be a non-empty list of dcjax.Recording")
    n = {len(r) for r in recordings}
    if len(n) != 1:
        raise ValueError(f"fleet recordings must have equal length, got lengths {sorted(n)}")
    if {r.i_a_limit is None for r in recordings} == {True, False}:
        raise ValueError("either every recording of a fleet has a current limit or none has")
    if not isinstance(runs, int) or isinstance(runs, bool) or runs < 1:
        raise ValueError(f"runs must be a positive integer, got {runs!r}")
    model = get_model(model)
    space = make_space(model, resolve_bounds(model, bounds), fixed)
    strategy = make_strategy(method, pop_size=pop_size)
    problems = [make_problem(r, model=model, integrator=integrator, nd=nd, weights=weights) for r in recordings]
    devices = devices or jax.devices()
    m = len(recordings)
    padded = padded_size(m, devices)
    problems += [problems[-1]] * (padded - m)
    stacked = jax.tree.map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *problems)
    mesh = mesh_of(devices, "fleet")
    arrays, static = eqx.partition(stacked, eqx.is_array)
    arrays = jax.tree.map(lambda a: shard(a, mesh, "fleet"), arrays)
    keys = shard(np.asarray(fold_keys(seed, padded, runs)), mesh, "fleet")

    def motor(prob_arrays, motor_keys):
        prob = eqx.combine(prob_arrays, static)
        fn = lambda z: objective(space.to_physical(z), prob)
        out = jax.vmap(lambda k: run(strategy, k, fn, budget, space.dim))(motor_keys)
        best = jnp.argmin(out.best_f)
        return space.to_physical(out.best_x[best]), out.best_f[best], out.fes

    batched = jax.jit(jax.vmap(motor))
    t0 = time.perf_counter()
    compiled = batched.lower(arrays, keys).compile()
    t1 = time.perf_counter()
    x, f, fes = jax.block_until_ready(compiled(arrays, keys))
    t2 = time.perf_counter()
    x, f, fes = (_to_host(a)[:m] for a in (x, f, fes))
    return FleetResult(
        params=x,
        of=f,
        fes=fes,
        timing={"compile_s": t1 - t0, "run_s": t2 - t1, "devices": len(devices), "motors_per_s": m / (t2 - t1)},
        settings={
            "method": method,
            "integrator": integrator,
            "nd": nd,
            "runs": runs,
            "budget": budget,
            "seed": seed,
            "pop_size": pop_size,
            "motors": m,
            "model": model.name,
            "fixed": space.fixed,
        },
        names=model.names,
    )
