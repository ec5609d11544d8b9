"""One NUTS chain's warm-up and draws as one loop over one kernel.

The warm-up is Stan's window adaptation as `blackjax.window_adaptation` runs it with a dense
metric: the step size by dual averaging towards the target acceptance (Hoffman & Gelman 2014,
sec. 3.2.1), the inverse mass matrix the Welford covariance of each slow window, shrunk towards
1e-3 I with weight 5 (Stan), the step size's averaging restarted at each window's end
(`build_schedule`'s windows), from blackjax's own parts (`dual_averaging_adaptation`,
`mass_matrix_adaptation`, `build_schedule`). `blackjax.window_adaptation` runs its steps in a
scan of their own, so that a sampler built on it compiles the NUTS kernel twice, its warm-up's and
its draws': here one `while` runs steps [start, stop) of warm-up and draws alike, the adaptation
held after the warm-up, and one executable serves the warm-up's call and the draws' (each timed)."""

from collections.abc import Callable
from typing import NamedTuple

import blackjax
import jax
import jax.numpy as jnp
import numpy as np
from blackjax.adaptation.mass_matrix import MassMatrixAdaptationState, mass_matrix_adaptation
from blackjax.adaptation.step_size import DualAveragingAdaptationState, dual_averaging_adaptation
from blackjax.adaptation.window_adaptation import build_schedule
from blackjax.mcmc.hmc import HMCState
from jaxtyping import Array, Float


class Tuning(NamedTuple):
    """The warm-up's state: the step size's dual averaging, the window's covariance, the step size
    and inverse mass matrix in force, and the tuned pair (`step_size`, `inverse_mass_matrix` of
    the draws: the averaged step size and the last window's matrix, set at the warm-up's last step)."""

    dual: DualAveragingAdaptationState
    window: MassMatrixAdaptationState
    step_size: Float[Array, ""]
    inverse_mass_matrix: Float[Array, "F F"]
    tuned_step_size: Float[Array, ""]
    tuned_inverse_mass_matrix: Float[Array, "F F"]


def _parts(target_acceptance: float):
    return dual_averaging_adaptation(target_acceptance), mass_matrix_adaptation(is_diagonal_matrix=False)


def tuning_init(dim: int, target_acceptance: float, step_size: float = 1.0) -> Tuning:
    """The warm-up's start: step size `step_size`, the identity matrix (blackjax's defaults)."""
    (da_init, _, da_final), (mm_init, _, _) = _parts(target_acceptance)
    dual, window = da_init(step_size), mm_init(dim)
    eye = window.inverse_mass_matrix
    tuning = Tuning(dual, window, jnp.asarray(step_size), eye, da_final(dual), eye)
    return jax.tree.map(lambda a: jnp.asarray(a, dtype=jnp.asarray(a).dtype), tuning)  # not weakly typed: the loop's own types


def tuning_update(tuning: Tuning, stage, window_end, position, acceptance, target_acceptance: float) -> Tuning:
    """One warm-up step's adaptation (`stage` 0: a fast window, the step size alone; 1: a slow one,
    the covariance too; `window_end`: a slow window's last step, its matrix in force from now)."""
    (da_init, da_update, da_final), (_, mm_update, mm_final) = _parts(target_acceptance)
    dual = da_update(tuning.dual, acceptance)
    window = jax.lax.cond(stage == 1, lambda w: mm_update(w, position), lambda w: w, tuning.window)

    def end(dual, window):  # the window's matrix in force; the step size's averaging restarts from its average
        return da_init(da_final(dual)), mm_final(window)

    dual, window = jax.lax.cond(window_end, end, lambda d, w: (d, w), dual, window)
    return tuning._replace(dual=dual, window=window, step_size=jnp.exp(dual.log_step_size), inverse_mass_matrix=window.inverse_mass_matrix)


def schedule(warmup: int, draws: int) -> Array:
    """(warmup + draws, 2): `build_schedule`'s (stage, window end) of the warm-up, then (0, False)."""
    warm = jnp.asarray(build_schedule(warmup), dtype=jnp.int32).reshape(warmup, 2) if warmup else jnp.zeros((0, 2), jnp.int32)
    return jnp.concatenate([warm, jnp.zeros((draws, 2), jnp.int32)])


class ChainState(NamedTuple):
    """A chain between the calls: its NUTS state and its tuning."""

    state: HMCState
    tuning: Tuning


def initial_chains(starts: Float[Array, "C F"]) -> ChainState:
    """Chains at `starts`, for a call from step 0 (which sets their states and tunings up): host
    arrays of the loop's types, so that building them compiles nothing."""
    chains, dim = starts.shape
    shapes = jax.eval_shape(lambda: tuning_init(dim, 0.8))  # its shapes and types (the target acceptance is no part of them)
    tuning = jax.tree.map(lambda a: np.zeros((chains, *a.shape), a.dtype), shapes)
    position = np.asarray(starts)
    state = HMCState(position, np.zeros(chains, position.dtype), np.zeros_like(position))  # pyright: ignore[reportArgumentType]
    return ChainState(state, tuning)


def chain_steps(
    logdensity: Callable,
    integrator,
    keys: tuple[Array, Array],
    chain: ChainState,
    start: Array,
    stop: Array,
    warmup: int,
    draws: int,
    target_acceptance: float,
):
    """Steps [start, stop) of a chain of `warmup` warm-up steps then `draws` draws (keys: the
    warm-up's and the draws' key, each split into one key a step as `blackjax.window_adaptation`
    and a scan of `kernel.step` split them). At step 0 the state is initialised from its position.
    Returns the chain after step stop - 1 and the draws' (draws, ...) records: the position and the
    sampler's statistics (diverging, integration steps, acceptance, energy, tree depth, log density),
    written for the draws among [start, stop) (zeros elsewhere)."""
    kernel = blackjax.nuts.build_kernel(integrator)
    step_keys = jnp.concatenate([jax.random.split(keys[0], warmup), jax.random.split(keys[1], draws)])
    stages = schedule(warmup, draws)
    position = jnp.asarray(chain.state.position)
    dim, dtype = position.shape[-1], position.dtype
    fresh = start == 0
    state = jax.lax.cond(fresh, lambda s: blackjax.nuts.init(s.position, logdensity), lambda s: s, chain.state)
    tuning = jax.tree.map(lambda a, b: jnp.where(fresh, a, b), tuning_init(dim, target_acceptance), chain.tuning)
    records = (
        jnp.zeros((draws, dim), dtype),
        (jnp.zeros(draws, bool), jnp.zeros(draws, jnp.int64), jnp.zeros(draws, dtype), jnp.zeros(draws, dtype)),
        (jnp.zeros(draws, jnp.int64), jnp.zeros(draws, dtype)),
    )

    def body(i, carry):
        state, tuning, records = carry
        warm = i < warmup
        step_size = jnp.where(warm, tuning.step_size, tuning.tuned_step_size)
        imm = jnp.where(warm, tuning.inverse_mass_matrix, tuning.tuned_inverse_mass_matrix)
        state, info = kernel(step_keys[i], state, logdensity, step_size, imm)
        stage = stages[i]
        adapted = tuning_update(tuning, stage[0], stage[1].astype(bool), state.position, info.acceptance_rate, target_acceptance)
        last = i == warmup - 1
        tuned = (jnp.exp(adapted.dual.log_step_size_avg), adapted.window.inverse_mass_matrix)
        adapted = adapted._replace(
            tuned_step_size=jnp.where(last, tuned[0], tuning.tuned_step_size),
            tuned_inverse_mass_matrix=jnp.where(last, tuned[1], tuning.tuned_inverse_mass_matrix),
        )
        tuning = jax.tree.map(lambda a, b: jnp.where(warm, a, b), adapted, tuning)
        k = jnp.maximum(i - warmup, 0)
        row = (
            state.position,
            (info.is_divergent, info.num_integration_steps.astype(jnp.int64), info.acceptance_rate, info.energy),
            (info.num_trajectory_expansions.astype(jnp.int64), state.logdensity),
        )
        records = jax.tree.map(lambda r, v: r.at[k].set(jnp.where(warm, r[k], v)), records, row)
        return state, tuning, records

    state, tuning, records = jax.lax.fori_loop(start, stop, body, (state, tuning, records))
    return ChainState(state, tuning), records
