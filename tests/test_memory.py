"""Memory assistance (paper Section 4.4): duplicates within precision are answered from memory
and not simulated; with no duplicate possible the search path is the memory-free one."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import make_problem, objective
from dcjax.fitting.runs import QUICK_COMPILE
from dcjax.models.dc import TABLE29, load_torque_precision
from dcjax.models.precision import unit_precision
from dcjax.strategies import make_strategy, run
from dcjax.strategies.compact import bucket_sizes, compacted
from dcjax.strategies.memory import LTMA, MEMORIES, Records

MEMORY_KINDS = tuple(MEMORIES)
BOX4, BOX8 = (dcjax.Bounds(p.lower, p.upper, dcjax.DC.names) for p in (dcjax.DC().parameters(k) for k in ("table4", "table8")))

PREC = jnp.asarray(unit_precision(TABLE29, BOX4))


def _mem(kind, chunk):
    """The memory of `kind` with LTMA's history searched in chunks of `chunk`."""
    m = MEMORIES[kind]
    return LTMA(order=m.order, chunk=chunk) if isinstance(m, LTMA) else m


@pytest.fixture(scope="module")
def sd1_fn(sd1):
    prob = make_problem(sd1)
    return lambda z: objective(BOX4.to_physical(z), prob)


def _run(fn, memory, precision=PREC, budget=2800, method="de-rand-1-exp", seed=0, **kw):
    s = make_strategy(method)
    run_of = lambda k: run(s, k, fn, budget, 7, memory=memory, precision=precision, **kw)
    return jax.jit(run_of, compiler_options=QUICK_COMPILE)(jax.random.PRNGKey(seed))  # as dcjax compiles a short search


@pytest.mark.slow
@pytest.mark.parametrize("memory", MEMORY_KINDS)
def test_precision_zero_gives_the_memory_free_path(sd1_fn, memory):
    off = _run(sd1_fn, None)
    on = _run(sd1_fn, memory, precision=jnp.zeros(7))
    assert int(on.dups) == 0 and int(on.fes) == int(off.fes) == 2800
    t = int(off.iterations)
    assert int(on.iterations) == t
    np.testing.assert_array_equal(np.asarray(on.history)[:t], np.asarray(off.history)[:t])
    np.testing.assert_array_equal(np.asarray(on.best_x), np.asarray(off.best_x))


@pytest.mark.slow
def test_precision_zero_path_under_vmap(sd1_fn):
    s = make_strategy("de-rand-1-exp")
    keys = jax.random.split(jax.random.PRNGKey(3), 3)
    off = jax.jit(jax.vmap(lambda k: run(s, k, sd1_fn, 1400, 7)), compiler_options=QUICK_COMPILE)(keys)
    on = jax.jit(jax.vmap(lambda k: run(s, k, sd1_fn, 1400, 7, memory="stma", precision=jnp.zeros(7))), compiler_options=QUICK_COMPILE)(
        keys
    )
    t = off.history.shape[1]
    np.testing.assert_array_equal(np.asarray(on.history)[:, :t], np.asarray(off.history))
    assert np.all(np.asarray(on.dups) == 0)


def test_bucket_sizes():
    assert bucket_sizes(70) == (70, 35, 18, 9, 5, 0)
    assert bucket_sizes(8) == (8, 0)


def _counting(fn, rows):
    """`fn` that reports at run time how many rows it was handed (`rows` gets their count per
    call). The callback sees a vmapped call's rows at once (`vmap_method="expand_dims"`: a
    `jax.debug.callback` under vmap is one callback a row, 560 of them compiled 6 s); its zero is
    added to the result so that it is not dropped."""

    def count(x):
        rows.append(int(np.size(x)))
        return np.zeros(np.shape(x)[:-1], x.dtype)

    def counted(z):
        zero = jax.pure_callback(count, jax.ShapeDtypeStruct(z.shape[:1], z.dtype), z[:, :1], vmap_method="expand_dims")
        return fn(z) + zero

    return counted


def test_compacted_skips_work_and_matches_fn():
    rows = []
    g = jax.jit(compacted(_counting(lambda z: jnp.sum(z**2, axis=-1), rows)))
    z = jax.random.uniform(jax.random.PRNGKey(0), (70, 7))
    full = np.asarray(jnp.sum(z**2, axis=-1))
    for k in (70, 30, 3, 0):
        active = jnp.arange(70) % 70 < k if k else jnp.zeros(70, bool)
        active = jax.random.permutation(jax.random.PRNGKey(k), active)
        rows.clear()
        f = np.asarray(g(z, active))
        jax.effects_barrier()
        a = np.asarray(active)
        np.testing.assert_allclose(f[a], full[a], rtol=1e-15)
        assert np.all(np.isinf(f[~a]))
        expected = min([s for s in bucket_sizes(70) if s >= k])
        assert sum(rows) == expected, (k, rows)


@pytest.mark.slow
def test_compacted_batches_across_runs():
    """Under vmap (and nested vmap) the active rows of all runs are evaluated together."""
    rows = []
    g = compacted(_counting(lambda z: jnp.sum(z, axis=-1), rows))
    z = jax.random.uniform(jax.random.PRNGKey(1), (2, 4, 70, 7))
    active = jax.random.uniform(jax.random.PRNGKey(2), (2, 4, 70)) < 0.1
    f = np.asarray(jax.jit(jax.vmap(jax.vmap(g)))(z, active))
    jax.effects_barrier()
    a = np.asarray(active)
    np.testing.assert_allclose(f[a], np.asarray(z).sum(-1)[a], rtol=1e-15)
    assert np.all(np.isinf(f[~a]))
    assert sum(rows) == min(s for s in bucket_sizes(560) if s >= a.sum())


@pytest.mark.slow
def test_forced_duplicate_is_not_simulated():
    """Candidates equal to the stored population are answered from memory: no row is simulated
    and no FE is spent; a perturbed candidate (beyond precision) is simulated."""
    from dcjax.strategies.base import State, evaluate

    rows = []
    fn = _counting(lambda z: jnp.sum(z**2, axis=-1), rows)
    pop = jax.random.uniform(jax.random.PRNGKey(0), (70, 7))
    fit = jnp.sum(pop**2, axis=-1)
    for kind in MEMORY_KINDS:
        mem = MEMORIES[kind].create(jnp.full(7, 1e-3), pop, fit, jnp.ones(70, bool), capacity=1000)
        state = State(pop, fit, pop[0], jnp.asarray(jnp.inf), jnp.asarray(70), None, jnp.asarray(0), mem)
        # within precision of its own record (the hash's test is the same cell: an exact repeat)
        z = pop + (0.0 if kind == "ltma-hash" else 1e-4)
        z = z.at[5].add(0.1)  # one real newcomer
        rows.clear()
        f, z_out, new = jax.jit(lambda z, s: evaluate(fn, z, s, 10_000))(z, state)
        jax.effects_barrier()
        assert sum(rows) == 5, (kind, rows)  # smallest bucket, one live row
        assert int(new.fes) == 71 and int(new.dups) == 69
        dup = np.arange(70) != 5
        np.testing.assert_array_equal(np.asarray(z_out)[dup], np.asarray(pop)[dup])  # the record's x ...
        np.testing.assert_array_equal(np.asarray(f)[dup], np.asarray(fit)[dup])  # ... and its OF
        assert float(f[5]) == pytest.approx(float(jnp.sum(z[5] ** 2)))
        if kind != "stma":
            assert int(new.memory.n) == 71


def test_s1_and_s2_find_the_same_duplicates():
    key = jax.random.PRNGKey(4)
    recs = jax.random.uniform(key, (3000, 7))
    cand = jnp.concatenate([recs[::97] + 1e-5, jax.random.uniform(jax.random.PRNGKey(5), (20, 7))])
    cand = cand.at[0].set(recs[0]).at[1].set(recs[2999])
    # A candidate matching two records: the oldest for S1, the newest for S2.
    recs = recs.at[2500].set(recs[10] + 2e-4)
    cand = cand.at[2].set(recs[10] + 1e-4)
    out = {}
    for kind in ("ltma-s1", "ltma-s2"):
        m = _mem(kind, 256).create(jnp.full(7, 1e-3), recs[:70], jnp.arange(70.0), jnp.ones(70, bool), 4000)
        m = m.add(recs[70:], jnp.arange(70, 3000.0), jnp.ones(2930, bool))
        found, x, f, m2 = jax.jit(Records.lookup)(m, cand)
        out[kind] = (np.asarray(found), np.asarray(f), int(m2.chunks))
    np.testing.assert_array_equal(out["ltma-s1"][0], out["ltma-s2"][0])
    n_copies = 3000 // 97 + 1
    assert out["ltma-s1"][0][:n_copies].all() and not out["ltma-s1"][0][n_copies:].any()
    assert out["ltma-s1"][1][2] == 10 and out["ltma-s2"][1][2] == 2500
    assert out["ltma-s1"][2] == out["ltma-s2"][2] == 12  # some not found: both scan everything


def test_s2_stops_early_on_recent_duplicates():
    """Candidates that copy the newest records: S2 finds them in its first chunk, S1 after
    scanning the whole history (the time difference of Tables 30–33)."""
    recs = jax.random.uniform(jax.random.PRNGKey(6), (3000, 7))
    chunks = {}
    for kind in ("ltma-s1", "ltma-s2"):
        m = _mem(kind, 256).create(jnp.full(7, 1e-3), recs[:70], jnp.zeros(70), jnp.ones(70, bool), 4000)
        m = m.add(recs[70:], jnp.zeros(2930), jnp.ones(2930, bool))
        found, x, _, m2 = jax.jit(Records.lookup)(m, recs[-70:] + 1e-5)
        assert np.all(np.asarray(found)) and np.array_equal(np.asarray(x), np.asarray(recs[-70:]))
        chunks[kind] = int(m2.chunks)
    assert chunks == {"ltma-s1": 12, "ltma-s2": 1}


def test_ltma_capacity_drops_overflow():
    pop = jnp.zeros((4, 7))
    m = LTMA(order="oldest", chunk=4).create(jnp.zeros(7), pop, jnp.zeros(4), jnp.ones(4, bool), capacity=6)
    m = m.add(jnp.ones((4, 7)), jnp.ones(4), jnp.ones(4, bool))
    assert int(m.n) == 6 and m.x.shape == (6, 7)


@pytest.mark.parametrize(
    "memory", [pytest.param(m, marks=() if m in ("stma", "ltma-hash") else pytest.mark.slow) for m in MEMORY_KINDS]
)  # the reproduction's two memories in the fast run, every one in the full run
def test_memory_never_changes_a_returned_of(sd1_fn, memory):
    out = _run(sd1_fn, memory, budget=7000, generations=300)
    assert int(out.dups) > 0
    # The returned OF is the one evaluated for best_x (re-evaluating in another batch shape may
    # round differently in the last bit, with or without memory).
    f = float(sd1_fn(out.best_x[None])[0])
    assert float(out.best_f) == pytest.approx(f, rel=1e-13)


@pytest.mark.slow
def test_memory_keeps_the_iteration_count_and_saves_fes(sd1_fn):
    """Paper Section 4.4: with memory a run makes the memory-free run's iterations, duplicates cost
    no FEs; with `generations` above that count the saved FEs buy more iterations within the budget."""
    off = _run(sd1_fn, None, budget=14_000)
    on = _run(sd1_fn, "stma", budget=14_000)
    assert int(on.iterations) == int(off.iterations) == 199 and int(on.dups) > 0
    assert int(on.fes) == 14_000 - int(on.dups)  # every candidate: FE or duplicate
    longer = _run(sd1_fn, "stma", budget=14_000, generations=400)
    assert int(longer.iterations) > 199 and int(longer.fes) <= 14_000


def test_fit_with_memory(sd1):
    r = dcjax.fit(
        sd1,
        "dc",
        "table4",
        dcjax.Search(make_strategy("de-rand-1-exp", generations=150), runs=3, budget=14_000, seed=2, memory=dcjax.STMA()),
    )
    assert r.dups is not None and np.all(r.fes <= 14_000) and np.all(r.iterations == 150)
    np.testing.assert_array_equal(r.fes + r.dups, 70 * 151)
    assert 0 < r.duplicates["percent"] < 100
    d = r.to_dict()
    assert d["settings"]["memory"] == "stma" and d["settings"]["precision"] == TABLE29.tolist()
    assert "dups" in d["runs"][0]


def test_memory_input_errors(sd1):
    with pytest.raises(ValueError, match="memory"):
        dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=1, budget=700, memory="ltma"))  # pyright: ignore[reportArgumentType]
    params = dcjax.DC().parameters("table4")
    params["Ra"].set(precision=-1.0)
    with pytest.raises(ValueError, match="precision"):
        dcjax.fit(sd1, params=params, search=dcjax.Search(runs=1, budget=700, memory=dcjax.STMA()))
    with pytest.raises(ValueError, match="generations"):
        dcjax.fit(sd1, params="table4", search=dcjax.Search(make_strategy("de-rand-1-exp", generations=0), runs=1, budget=700))
    with pytest.raises(ValueError, match="positive"):
        load_torque_precision(0.0, 209.0, 1e-3, 1e-3, 1e-3, 1e-4)


def test_table29_rule_and_unit_precision():
    np.testing.assert_allclose(load_torque_precision(1e-3, 209.0, 1e-3, 1e-3, 1e-3, 1e-4)[5:], [4.78e-6, 2.29e-8], rtol=1e-2)
    u = unit_precision(None, BOX8)
    np.testing.assert_allclose(u * np.asarray(BOX8.upper - BOX8.lower), TABLE29)


@pytest.mark.slow
def test_cli_memory(tmp_path, capsys):
    import json
    from pathlib import Path

    from dcjax.cli import main

    data = Path(__file__).resolve().parent.parent / "data" / "MD1.csv"
    rc = main(["fit", str(data), "--runs", "2", "--budget", "7000", "--memory", "ltma-s2", "--generations", "30", "--out", str(tmp_path)])
    assert rc == 0
    out = capsys.readouterr().out
    assert "memory ltma-s2:" in out and "% of candidates answered from memory" in out
    d = json.loads((tmp_path / "result.json").read_text())
    assert d["settings"]["memory"] == "ltma-s2" and all(r["iterations"] == 30 for r in d["runs"])


def test_cli_rejects_unknown_memory(capsys):
    from dcjax.cli import main

    assert main(["fit", "SD1", "--memory", "ltma"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("dcjax: error: argument --memory: invalid choice: 'ltma'")


@pytest.mark.slow  # > 4 s: the full run's
def test_hash_memory_finds_the_same_cell_only():
    from dcjax.strategies.memory import HashRecords

    prec = jnp.full(7, 0.1)
    rec = jnp.full((1, 7), 0.55)
    m = HashRecords.create(prec, rec, jnp.asarray([3.0]), jnp.ones(1, bool), capacity=10)
    same, other = jnp.full(7, 0.51), jnp.full(7, 0.55).at[3].set(0.61)  # same cell / next cell in one parameter
    found, x, f, m = m.lookup(jnp.stack([same, other]))
    assert found.tolist() == [True, False] and float(f[0]) == 3.0 and np.array_equal(x[0], rec[0])
    # two new candidates of one cell in a batch: the first is stored, the second is not
    m = m.add(jnp.stack([jnp.full(7, 0.21), jnp.full(7, 0.22)]), jnp.asarray([1.0, 2.0]), jnp.ones(2, bool))
    assert int(m.n) == 2
    found, _, f, _ = m.lookup(jnp.full((1, 7), 0.25))
    assert bool(found[0]) and float(f[0]) == 1.0


@pytest.mark.slow
@pytest.mark.parametrize("memory", [None, "stma", "ltma-s2", "ltma-hash"])
def test_run_batch_equals_separate_runs(sd1_fn, memory):
    """`run_batch` (one loop over all runs, finished runs masked) gives each run's own result."""
    from dcjax.strategies.loop import run_batch

    s = make_strategy("de-rand-1-exp")
    keys = jax.random.split(jax.random.PRNGKey(7), 3)
    prec = None if memory is None else PREC
    kw = dict(memory=memory, precision=prec)  # with memory, runs end at different iterations (budget)
    budgets = 1050
    batch = jax.jit(lambda k: run_batch(s, k, sd1_fn, budgets, 7, **kw), compiler_options=QUICK_COMPILE)(keys)
    one_run = jax.jit(lambda k: run(s, k, sd1_fn, budgets, 7, **kw), compiler_options=QUICK_COMPILE)  # compiled once, called per run
    for r in range(3):
        one = one_run(keys[r])
        for field in ("best_x", "best_f", "fes", "iterations", "history", "dups"):
            np.testing.assert_array_equal(getattr(batch, field)[r], getattr(one, field), err_msg=field)
