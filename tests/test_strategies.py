"""Search strategies: improvement, FE accounting, bounds, non-finite handling, jit/vmap."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import make_problem, objective
from dcjax.fitting.runs import QUICK_COMPILE
from dcjax.strategies import DEBest1Bin, Evosax, State, make_strategy, run
from dcjax.strategies.base import apply_bounds, distinct_indices, evaluate, index_below
from dcjax.strategies.de import binomial_crossover, exponential_crossover

METHODS = ["ga", "de-rand-1-exp", "de-best-1-bin", "tlbo", "abc"]
TARGET = jnp.array([0.3, 0.7, 0.5, 0.2, 0.9, 0.4, 0.6])


def sphere(z):
    return jnp.sum((z - TARGET) ** 2, axis=-1)


def _run(method, fn, budget, seed=0, **kw):
    s = make_strategy(method, **kw)
    return jax.jit(lambda k: run(s, k, fn, budget, 7), compiler_options=QUICK_COMPILE)(
        jax.random.PRNGKey(seed)
    )  # as dcjax compiles a short search


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_improves_on_convex_function(method):
    out = _run(method, sphere, 7000)
    init_best = float(_run(method, sphere, 70).best_f)
    assert float(out.best_f) < 1e-3 * init_best, (method, float(out.best_f), init_best)
    h = np.asarray(out.history)[: int(out.iterations)]
    assert np.all(np.diff(h) <= 0), "best-so-far must never get worse"


@pytest.fixture(scope="module")
def sd1_fn(sd1):
    prob = make_problem(sd1)
    box = dcjax.DC().parameters("table4")
    return lambda z: objective(box.lower + z * (box.upper - box.lower), prob)


@pytest.mark.slow
@pytest.mark.parametrize("method", METHODS)
def test_improves_on_sd1(method, sd1_fn):
    init_best = float(_run(method, sd1_fn, 70).best_f)
    out = _run(method, sd1_fn, 7000)
    assert float(out.best_f) < 0.5 * init_best
    x = np.asarray(out.best_x)
    assert np.all((x >= 0) & (x <= 1))


@pytest.mark.slow
@pytest.mark.parametrize("budget", [140_000, 10_001])
def test_fe_accounting(budget):
    out = {m: _run(m, sphere, budget) for m in METHODS}
    for m in METHODS:
        assert int(out[m].fes) <= budget
    # TLBO: 2 x NP x iterations after the initial population.
    if budget == 140_000:
        assert int(out["tlbo"].fes) == budget and int(out["tlbo"].iterations) == (budget - 70) // 140 + 1
        assert int(out["de-rand-1-exp"].iterations) == 1999 and int(out["ga"].iterations) == 1999
    # DE, TLBO and ABC stop exactly at the budget; GA only runs whole generations.
    for m in ("de-rand-1-exp", "de-best-1-bin", "tlbo", "abc"):
        assert int(out[m].fes) == budget, m
    assert budget - 70 < int(out["ga"].fes) <= budget


def test_abc_counts_scouts():
    """Every candidate fails (non-finite), so after `limit` failures a scout flies each
    iteration and costs one FE: fewer iterations than (budget - SN) / 70."""
    failing = lambda z: jnp.full(z.shape[0], jnp.nan)
    out = _run("abc", failing, 140_000)
    assert int(out.fes) == 140_000
    assert int(out.iterations) < (140_000 - 35) // 70


@pytest.mark.parametrize("method", METHODS)
def test_non_finite_never_selected(method):
    """NaN where z0 < 0.5 and inf where z1 < 0.3: the best is always in the finite region."""

    def fn(z):
        f = sphere(z)
        f = jnp.where(z[:, 0] < 0.5, jnp.nan, f)
        return jnp.where(z[:, 1] < 0.3, jnp.inf, f)

    out = _run(method, fn, 3500)
    x = np.asarray(out.best_x)
    assert np.isfinite(float(out.best_f)) and x[0] >= 0.5 and x[1] >= 0.3


def test_a_budget_the_initial_population_spends_compiles_no_loop():
    """`max_iterations(budget) == 0` exactly where the run loop would make no step (the largest
    such budget: the loop's condition false after the initial population; the next: true);
    there `run_batch` leaves the loop out of the program: the initial population's best, no
    iteration."""
    from dcjax.strategies.base import with_best
    from dcjax.strategies.loop import RunCarry, run_active, run_batch

    key = jax.random.PRNGKey(3)
    budgets = jnp.arange(5, 40)  # traced: one program a strategy (below a population no step fits either way)
    evaluated = lambda s, k: RunCarry(
        with_best(s.init(k, sphere, 40, 7)), jnp.asarray(0), jnp.full(40, jnp.nan), k
    )  # the initial population's
    enters = jax.jit(lambda s, k: jax.vmap(lambda b: run_active(s, evaluated(s, k), b, 40))(budgets), static_argnums=0)
    for method in METHODS:
        s = make_strategy(method, pop_size=10)
        none = [s.max_iterations(int(b)) == 0 for b in budgets]  # GA's whole step costs a population, ABC's bees are twice its sources
        assert list(~np.asarray(enters(s, key))) == none and 1 <= sum(none) < len(none), method
    s, keys = make_strategy("de-best-1-bin", pop_size=10), jax.random.split(key, 2)
    whiles = lambda b: str(jax.make_jaxpr(lambda k: run_batch(s, k, sphere, b, 7))(keys)).count("while[")
    assert whiles(10) < whiles(11)  # the random draws' own loops aside
    out = jax.jit(lambda k: run_batch(s, k, sphere, 10, 7))(keys)
    assert list(out.iterations) == [0, 0] and list(out.fes) == [10, 10] and np.all(np.isnan(out.history)) and not np.any(out.converged)
    np.testing.assert_array_equal(out.best_f, sphere(out.best_x))


@pytest.mark.parametrize(
    "method", [pytest.param(m, marks=() if m == "de-rand-1-exp" else pytest.mark.slow) for m in METHODS]
)  # the paper's DE (also a run alone) in the fast run: 4 s a strategy, mostly compiling
def test_the_initial_population_evaluated_in_the_loop_gives_the_bits_of_before_it(method, monkeypatch):
    """Each strategy evaluates its initial population in the run loop's first pass (`pending`):
    its program evaluates the objective at one place fewer than with `init` before the loop, and
    the runs are the same (best, FEs, iterations, history, to the bit), with a stopping rule that
    ends them early, a batch of runs and (DE/rand/1/exp, the paper's) one run alone. (The
    objective's own last bit may differ where XLA compiles its copy in the loop otherwise than
    the one before it: seen on a sum of sines, not on dcjax's simulations, `experiments.same_bits`.)"""
    from dcjax.strategies.loop import run_batch

    s, keys = make_strategy(method, pop_size=10), jax.random.split(jax.random.PRNGKey(5), 3)
    sites: list = []

    def fn(z):
        sites.append(z.shape)  # one entry per place the traced program evaluates the objective
        return sphere(z)

    def searched():
        sites.clear()
        batch = jax.jit(
            lambda k: run_batch(s, k, fn, 900, 7, stop=dcjax.Converged(rtol=0.0, atol=1e-3, patience=3)), compiler_options=QUICK_COMPILE
        )(keys)
        one = jax.jit(lambda k: run(s, k, fn, 900, 7), compiler_options=QUICK_COMPILE)(keys[0]) if method == "de-rand-1-exp" else None
        return (batch, one), len(sites)

    (folded, sites_folded) = searched()
    monkeypatch.setattr(type(s), "evaluates_pending", False)  # `init` evaluates before the loop
    (before, sites_before) = searched()
    assert sites_folded == sites_before - (2 if method == "de-rand-1-exp" else 1), (sites_folded, sites_before)
    for a, b in zip(jax.tree.leaves(folded), jax.tree.leaves(before), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    batch = folded[0]
    assert np.all(batch.iterations >= 1) and np.any(batch.converged), (batch.iterations, batch.converged)
    np.testing.assert_allclose(batch.best_f, np.asarray(sphere(batch.best_x)), rtol=1e-14)


def test_a_batch_whose_runs_stop_apart_gives_each_runs_bits_alone():
    """`run_batch` tests the stopping rule once an iteration and carries the result (the loop's
    condition, the mask of finished runs, `converged` in the output): runs that converge at
    different iterations, and one that spends its budget, end as each run alone does, to the bit."""
    from dcjax.strategies.loop import run_batch

    s, keys = make_strategy("de-rand-1-exp", pop_size=10), jax.random.split(jax.random.PRNGKey(11), 4)
    stop = dcjax.Converged(rtol=0.0, atol=1e-3, patience=3)
    batch = jax.jit(lambda k: run_batch(s, k, sphere, 480, 7, stop=stop), compiler_options=QUICK_COMPILE)(keys)
    one = jax.jit(lambda k: run(s, k, sphere, 480, 7, stop=stop), compiler_options=QUICK_COMPILE)
    for r in range(keys.shape[0]):
        for a, b in zip(jax.tree.leaves(jax.tree.map(lambda x, r=r: x[r], batch)), jax.tree.leaves(one(keys[r])), strict=True):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert len(set(np.asarray(batch.iterations).tolist())) > 1 and np.any(batch.converged) and not np.all(batch.converged), batch


@pytest.mark.slow
@pytest.mark.parametrize("method", ["de-rand-1-exp", "abc"])
def test_vmap_over_runs_equals_separate_runs(method, sd1_fn):
    s = make_strategy(method)
    keys = jax.random.split(jax.random.PRNGKey(7), 3)
    f = lambda k: run(s, k, sd1_fn, 1400, 7)
    batched = jax.jit(jax.vmap(f), compiler_options=QUICK_COMPILE)(keys)
    single_run = jax.jit(f, compiler_options=QUICK_COMPILE)  # compiled once, called per run
    for r in range(3):
        single = single_run(keys[r])
        np.testing.assert_allclose(batched.best_f[r], single.best_f, rtol=1e-12)
        np.testing.assert_allclose(batched.best_x[r], single.best_x, rtol=1e-12)
        assert int(batched.fes[r]) == int(single.fes)


def test_distinct_indices():
    n = 70
    idx = distinct_indices(jax.random.uniform(jax.random.PRNGKey(0), (n, 3)), n, jnp.arange(n))
    all_ = np.concatenate([np.arange(n)[:, None], np.asarray(idx)], axis=1)
    assert all(len(set(row)) == 4 for row in all_)
    assert idx.min() >= 0 and idx.max() < n
    many = np.asarray(distinct_indices(jax.random.uniform(jax.random.PRNGKey(1), (20000, 1)), 5, jnp.zeros(20000, int)))[:, 0]
    counts = np.bincount(many, minlength=5)
    assert counts[0] == 0 and np.all(np.abs(counts[1:] / 20000 - 0.25) < 0.02)
    # pairs: each ordered pair of distinct indices (both != the excluded 0) equally likely
    pairs = np.asarray(distinct_indices(jax.random.uniform(jax.random.PRNGKey(2), (60000, 2)), 5, jnp.zeros(60000, int)))
    assert np.all(pairs[:, 0] != pairs[:, 1]) and pairs.min() >= 1
    freq = np.bincount(pairs[:, 0] * 5 + pairs[:, 1], minlength=25).reshape(5, 5)[1:, 1:]
    off = ~np.eye(4, dtype=bool)
    assert np.all(np.abs(freq[off] / 60000 - 1 / 12) < 0.01)


def test_index_below_is_uniform_and_in_range():
    u = jnp.array([0.0, 0.2499, 0.25, 0.9999999999999999])
    np.testing.assert_array_equal(index_below(u, 4), [0, 0, 1, 3])
    k = np.asarray(index_below(jax.random.uniform(jax.random.PRNGKey(3), (40000,)), 7))
    assert k.min() == 0 and k.max() == 6 and np.all(np.abs(np.bincount(k) / 40000 - 1 / 7) < 0.01)


def test_crossovers():
    p, d = 2000, 7
    target, mutant = jnp.zeros((p, d)), jnp.ones((p, d))
    exp = np.asarray(exponential_crossover(jax.random.uniform(jax.random.PRNGKey(0), (p, d)), target, mutant, 0.8))
    assert np.all(exp.sum(1) >= 1)
    for row in exp:  # one contiguous cyclic block of mutant genes
        assert np.sum(np.abs(np.diff(np.r_[row, row[0]]))) <= 2
    # mean block length (1 - CR^D) / (1 - CR)
    np.testing.assert_allclose(exp.sum(1).mean(), (1 - 0.8**7) / 0.2, rtol=0.05)
    binm = np.asarray(binomial_crossover(jax.random.uniform(jax.random.PRNGKey(1), (p, d + 1)), target, mutant, 0.8))
    assert np.all(binm.sum(1) >= 1)
    np.testing.assert_allclose(binm.mean(), 0.8 + 0.2 / 7, rtol=0.03)


def test_bound_rules():
    z = jnp.array([[-0.5, 0.5, 1.5]])
    parent = jnp.array([[0.2, 0.5, 0.8]])
    u = jnp.array([[0.3, 0.6, 0.9]])  # the variates a redraw takes
    r = np.asarray(apply_bounds(u, z, "redraw"))
    np.testing.assert_array_equal(r, [[0.3, 0.5, 0.9]])
    np.testing.assert_array_equal(apply_bounds(u, z, "clip"), [[0.0, 0.5, 1.0]])
    np.testing.assert_allclose(apply_bounds(u, z, "midpoint", parent), [[0.1, 0.5, 0.9]])
    with pytest.raises(ValueError, match="bounds rule"):
        apply_bounds(u, z, "wrap")


def test_evaluate_respects_budget():
    z = jnp.full((10, 7), 0.5)
    state = State(z, jnp.zeros(10), z[0], jnp.asarray(jnp.inf), jnp.asarray(95), None, jnp.asarray(0))
    f, _, state = evaluate(sphere, z, state, 100)
    fes = state.fes
    assert int(fes) == 100 and np.all(np.isinf(np.asarray(f)[5:])) and np.all(np.isfinite(np.asarray(f)[:5]))


@pytest.mark.parametrize("name", ["CMA_ES", "PSO", "DifferentialEvolution"])
def test_evosax_adapter(name):
    out = _run(name, sphere, 7000)
    assert float(out.best_f) < 1e-2 and int(out.fes) <= 7000
    x = np.asarray(out.best_x)
    assert np.all((x >= 0) & (x <= 1))


@pytest.mark.slow  # > 4 s: the full run's
def test_rank_weights_are_evosax_weights_to_the_bit_ties_and_nan_included(monkeypatch):
    """dcjax's pairwise ranks against evosax's own `weights_fitness_shaping_fn` (rankdata's sorts):
    the same weights on fitness with ties, +inf and NaN, and a CMA-ES run the same bits with either."""
    import evosax.algorithms as ea
    from evosax.core.fitness_shaping import weights_fitness_shaping_fn

    from dcjax.strategies.evosax_adapter import rank_weights

    params = ea.algorithms["CMA_ES"](population_size=12, solution=jnp.zeros(3)).default_params
    rng = np.random.default_rng(0)
    fits = rng.integers(0, 4, (300, 12)).astype(float)
    fits[rng.random(fits.shape) < 0.15] = np.inf
    fits[rng.random(fits.shape) < 0.1] = np.nan
    fits = np.concatenate([fits, np.full((1, 12), np.nan), rng.normal(size=(20, 12))])
    ours = jax.vmap(lambda f: rank_weights(None, f, None, params))(jnp.asarray(fits))
    theirs = jax.vmap(lambda f: weights_fitness_shaping_fn(None, f, None, params))(jnp.asarray(fits))
    np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs))
    with_ours = _run("CMA_ES", sphere, 1200)
    monkeypatch.setattr(Evosax, "_algo", lambda self, dim: ea.algorithms[self.name](population_size=self.pop_size, solution=jnp.zeros(dim)))
    with_theirs = _run("CMA_ES", sphere, 1200)
    np.testing.assert_array_equal(np.asarray(with_ours.best_x), np.asarray(with_theirs.best_x))
    np.testing.assert_array_equal(np.asarray(with_ours.history), np.asarray(with_theirs.history))


@pytest.mark.slow
def test_evosax_de_cross_checks_de_best_1_bin():
    """evosax's DifferentialEvolution with elitism is DE/best/1/bin; with F = 0.6, CR = 0.8 both
    implementations reach the sphere's optimum to a similar accuracy (median of 4 seeds)."""
    ev = Evosax(
        name="DifferentialEvolution",
        params=dict(elitism=True, crossover_rate=0.8, differential_weight=0.6, differential_weight_min=0.6, differential_weight_max=0.6),
    )
    ours = DEBest1Bin()
    med = {}
    for label, s in (("evosax", ev), ("dcjax", ours)):
        f = jax.jit(jax.vmap(lambda k, s=s: run(s, k, sphere, 14_000, 7)), compiler_options=QUICK_COMPILE)
        med[label] = float(np.median(np.asarray(f(jax.random.split(jax.random.PRNGKey(0), 4)).best_f)))
    assert med["evosax"] < 1e-12 and med["dcjax"] < 1e-12, med
    assert 1e-4 < med["dcjax"] / med["evosax"] < 1e4, med


def test_bad_strategy_options():
    with pytest.raises(ValueError, match="unknown method"):
        make_strategy("simplex")
    with pytest.raises(ValueError, match="bounds_rule"):
        make_strategy("de-rand-1-exp", bounds_rule="bounce")
    with pytest.raises(ValueError, match="unknown evosax"):
        Evosax(name="NoSuchES")


def test_cma_es_is_a_named_method_with_its_own_population(sd1):
    s = make_strategy("cma-es")
    assert type(s).__name__ == "Evosax" and s.name == "CMA_ES" and s.pop_size == 12 and make_strategy("CMA_ES").pop_size == 70
    r = dcjax.fit(sd1, params="table4", search=dcjax.Search("cma-es", runs=1, budget=700))
    assert r.settings["method"] == "CMA_ES" and np.isfinite(r.of) and int(r.fes[0]) <= 700
