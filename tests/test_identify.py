"""fit(), the LM polish, the result object and the CLI."""

import dataclasses
import gc
import json
import os
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import datasets, make_problem
from dcjax.cli import main
from dcjax.fitting.polish import levenberg_marquardt, polish_jit
from dcjax.strategies import DERand1Exp, make_strategy

NAMES = dcjax.DC.names
BOX4 = dcjax.Bounds(dcjax.DC().parameters("table4").lower, dcjax.DC().parameters("table4").upper, NAMES)


def fit(rec, params="table4", search=None, **kw):
    """`dcjax.fit` with Table 4's ranges; a `Search` field given by its name (`runs=3`) goes into `search`."""
    given = {k: kw.pop(k) for k in ("method", "runs", "budget", "seed", "memory", "polish") if k in kw}
    return dcjax.fit(rec, params=params, search=dataclasses.replace(search or dcjax.Search(), **given), **kw)


ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("name", ["SD1", "SD2", "SD3", "SD4"])
def test_de_rand_1_exp_recovers_sd_parameters(name):
    """Paper Table 5/6: DE/rand/1/exp with RK4, NP = 70, 140,000 FEs (here 2 runs per set;
    the 50-run check is experiments/table5_sd.py)."""
    r = fit(datasets.load(name), search=dcjax.Search("de-rand-1-exp", runs=2, seed=1))
    assert np.all(r.run_of <= 1e-15), r.run_of
    truth = datasets.true_params(name)
    for x in r.run_params:
        for k, n in enumerate(NAMES):
            assert abs(x[k] - truth[n]) <= 1e-6 * abs(truth[n]), (name, n, x[k], truth[n])
    assert np.all(r.fes == 140_000)


@pytest.mark.slow
def test_table5_ranking_on_sd1():
    """DE/rand/1/exp best, GA worst (2 runs each, full budget)."""
    means = {
        m: fit(datasets.load("SD1"), search=dcjax.Search(m, runs=2, seed=0)).stats["mean"]
        for m in ("ga", "de-rand-1-exp", "de-best-1-bin", "tlbo", "abc")
    }
    assert means["de-rand-1-exp"] <= 1e-25
    assert means["ga"] == max(means.values())
    for m in ("tlbo", "abc", "ga"):
        assert means[m] > 1e6 * means["de-rand-1-exp"], means
    # DE/best/1/bin either ties at the numerical floor or is worse.
    assert means["de-best-1-bin"] >= means["de-rand-1-exp"] or means["de-best-1-bin"] <= 1e-25, means


def test_same_seed_same_result_different_seed_different(sd1):
    kw = dict(method="de-rand-1-exp", runs=3, budget=3500)
    a, b, c = (
        fit(sd1, **kw, seed=5),
        fit(sd1, **kw, seed=5),
        fit(sd1, **kw, seed=6),
    )
    np.testing.assert_array_equal(a.run_of, b.run_of)
    np.testing.assert_array_equal(a.run_params, b.run_params)
    np.testing.assert_array_equal(a.history, b.history)
    assert not np.array_equal(a.run_params, c.run_params)
    assert len(set(a.run_of.tolist())) == 3, "runs of one call must differ"


@pytest.mark.slow
def test_sharded_runs_equal_single_device(tmp_path):
    """The same call with 1 and 2 XLA CPU devices gives identical results (3 runs: padded)."""
    code = (
        "import sys, json, dcjax; from dcjax import datasets;"
        "r = dcjax.fit(datasets.load('SD1'), params='table4', search=dcjax.Search(runs=3, budget=2100, seed=2));"
        "print(json.dumps({'of': r.run_of.tolist(), 'x': r.run_params.tolist(), 'dev': r.timing['devices']}))"
    )
    outs = {}
    for n in (1, 2):
        env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={n}")
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
        outs[n] = json.loads(p.stdout.strip().splitlines()[-1])
    assert outs[1]["dev"] == 1 and outs[2]["dev"] == 2
    assert outs[1]["of"] == outs[2]["of"] and outs[1]["x"] == outs[2]["x"]


def test_result_object(sd1, tmp_path):
    r = fit(sd1, search=dcjax.Search("tlbo", runs=2, budget=2100, seed=0))
    d = json.loads(r.to_json(tmp_path / "r.json"))
    assert set(d["params"]) == set(NAMES) and d["of"] == min(x["of"] for x in d["runs"])
    assert set(d["stats"]) == {"best", "worst", "mean", "std"} and len(d["runs"]) == 2
    assert r.history.shape == (2, 15) and np.all(np.diff(r.history, axis=1) <= 0)
    assert np.all(r.fes == 2100)
    for x in r.run_params:
        assert BOX4.contains(x)
    r.plot(tmp_path / "fit.png")
    assert (tmp_path / "fit.png").stat().st_size > 10_000
    assert r.simulate().shape == (len(sd1), 2) and r.simulate().dtype == np.float64


def test_polish_improves_and_keeps_bounds(sd1, sd1_true):
    prob = make_problem(sd1)
    truth = jnp.asarray([sd1_true[n] for n in NAMES])
    x0 = truth * jnp.array([1.01, 0.99, 1.0, 1.02, 0.97, 1.1, 0.9])
    r = polish_jit(x0, prob, BOX4)
    assert float(r.of_before) > 1e-6 and float(r.of_after) < 1e-20
    np.testing.assert_allclose(np.asarray(r.x), np.asarray(truth), rtol=1e-8)
    # A start on the upper bound of Tlc stays within the bounds.
    x_edge = truth.at[6].set(1e-6)
    r2 = polish_jit(x_edge, prob, BOX4)
    assert BOX4.contains(np.asarray(r2.x)) and float(r2.of_after) <= float(r2.of_before)


def test_the_polish_compiles_lean_to_the_bits_of_xlas_own_options(sd1, sd1_true):
    """With compiled loops (this test session's, `conftest.py`) the polish is compiled without
    the fusion emitters (`polish._compiled`) and ends on the same bits as with XLA's options."""
    from dcjax.compiling import filter_jit
    from dcjax.devices import COMPILED_LOOP_BYTES, compiled_loop_bytes
    from dcjax.fitting.polish import polish

    assert compiled_loop_bytes() >= COMPILED_LOOP_BYTES
    prob = make_problem(sd1)
    x0 = jnp.asarray([sd1_true[n] for n in NAMES]) * jnp.array([1.01, 0.99, 1.0, 1.02, 0.97, 1.1, 0.9])
    lean, full = polish_jit(x0, prob, BOX4), filter_jit(polish, options={})(x0, prob, BOX4)
    assert np.array_equal(np.asarray(lean.x), np.asarray(full.x)) and float(lean.of_after) == float(full.of_after)
    assert int(lean.steps) == int(full.steps) > 1


def test_levenberg_marquardt_reaches_scipys_least_squares_optimum():
    """dcjax's LM against scipy's (MINPACK-style trust region, an independent implementation): the
    Rosenbrock residuals (zero-residual optimum at (1, 1)) and a noisy exponential decay (a
    non-zero residual optimum)."""
    from scipy.optimize import least_squares

    y, cost, _, converged = levenberg_marquardt(lambda y: jnp.stack([10.0 * (y[1] - y[0] ** 2), 1.0 - y[0]]), jnp.array([-1.2, 1.0]))
    assert bool(converged) and float(cost) < 1e-25
    np.testing.assert_allclose(np.asarray(y), [1.0, 1.0], rtol=1e-10)
    t = np.linspace(0.0, 4.0, 40)
    data = 2.5 * np.exp(-1.3 * t) + 0.5 + 0.01 * np.random.default_rng(0).standard_normal(40)
    y, cost, _, converged = levenberg_marquardt(lambda p: p[0] * jnp.exp(-p[1] * t) + p[2] - data, jnp.array([1.0, 1.0, 0.0]))
    want = least_squares(lambda p: p[0] * np.exp(-p[1] * t) + p[2] - data, [1.0, 1.0, 0.0], xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert bool(converged)
    np.testing.assert_allclose(np.asarray(y), want.x, rtol=1e-8)
    assert float(cost) == pytest.approx(2 * want.cost, rel=1e-12)  # scipy's cost is half the sum of squares
    # the residuals' count given (as `polish` gives it) instead of found by one more trace: the same bits
    given = levenberg_marquardt(lambda p: p[0] * jnp.exp(-p[1] * t) + p[2] - data, jnp.array([1.0, 1.0, 0.0]), residuals=40)
    assert np.array_equal(np.asarray(given[0]), np.asarray(y)) and float(given[1]) == float(cost)


@pytest.mark.slow
def test_polish_flag(sd1):
    r = fit(sd1, search=dcjax.Search("ga", runs=2, budget=1400, seed=0, polish=True))
    assert np.all(np.asarray(r.polish["of_after"]) <= np.asarray(r.polish["of_before"]))
    np.testing.assert_array_equal(r.run_of, r.polish["of_after"])


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(runs=0), "runs"),
        (dict(budget=10), "budget"),
        (dict(method="nope"), "unknown method"),
        (dict(params="table9"), "unknown bounds"),
        (dict(integrator="rk2"), "integrator"),
        (dict(observation={"loss": "l1"}), "observation must be a dcjax.Observation"),
    ],
)
def test_fit_bad_input(sd1, kw, match):
    with pytest.raises(ValueError, match=match):
        fit(sd1, **kw)


def test_cli_writes_result(tmp_path, capsys):
    rc = main(["fit", str(ROOT / "data" / "SD1.csv"), "--runs", "2", "--budget", "2100", "--out", str(tmp_path)])
    assert rc == 0
    d = json.loads((tmp_path / "result.json").read_text())
    for key in ("params", "of", "runs", "stats", "settings", "timing"):
        assert key in d
    assert set(d["params"]) == set(NAMES)
    assert all(set(r) >= {"of", "params"} for r in d["runs"])
    assert set(d["timing"]) >= {"compile_s", "run_s"}
    assert (tmp_path / "fit.png").is_file()
    out = capsys.readouterr().out
    assert "Ra" in out and "true" in out


@pytest.mark.parametrize(
    "args,match",
    [
        (["fit", "missing.csv"], "no such file"),
        (["fit", "SD1", "--weights", "1"], "--weights"),
        (["fit", "SD1", "--lower", "0,0,0,0,0,0,0"], "together"),
        (["fit", "SD1", "--bounds", "table4", "--lower", "0,0,0,0,0,0,0", "--upper", "1,1,1,1,1,1,1"], "either"),
        (["fit", "SD1", "--runs", "0"], "runs"),
        (["fit", "SD1", "--method", "xx"], "unknown method"),
        (["fit", "SD1", "--i-limit", "-3"], "current limit"),
    ],
)
def test_cli_bad_input(args, match, capsys, tmp_path):
    assert main(args + ["--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err and err.count("\n") == 1


def test_cli_module_entry_bad_file(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u_a,i_a,omega\n0,1,0,0\n0.1,1,0,0\n0.2,1,0,0\n")
    p = subprocess.run([sys.executable, "-m", "dcjax", "fit", str(bad)], capture_output=True, text=True)
    assert p.returncode != 0 and "all zero" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow  # 6 s: the same search compiled at two levels
def test_a_short_search_compiles_quick_to_the_same_bits(sd1, monkeypatch):
    """A run shorter than about a compilation is compiled at LLVM level 2 (`QUICK_COMPILE`, about
    half the compile time): the same runs as at XLA's default level 3; a long run keeps the
    default, and the level depends on one run's work, not on how many runs there are."""
    runs = sys.modules["dcjax.fitting.runs"]
    assert runs.compiler_options(1e6) == runs.QUICK_COMPILE and runs.compiler_options(1e12) is None
    mid = runs.COMPILE_FES / 2  # a plain search of this much work compiles quick, a memory-assisted one not
    assert runs.compiler_options(mid) == runs.QUICK_COMPILE and runs.compiler_options(mid, plain=False) is None
    seen = []
    monkeypatch.setattr(runs, "compiler_options", lambda work, plain=True: seen.append(work) or runs.QUICK_COMPILE)
    quick = dcjax.fit(sd1, search=dcjax.Search(runs=2, budget=700, seed=3))
    dcjax.fit(sd1, search=dcjax.Search(runs=4, budget=700, seed=3))
    assert seen == [700 * len(sd1.t)] * 2  # RK4, one sub-step: budget x samples, whatever the runs
    monkeypatch.setattr(runs, "compiler_options", lambda work, plain=True: None)
    default = dcjax.fit(sd1, search=dcjax.Search(runs=2, budget=700, seed=3))
    assert not default.timing["reused_executable"]  # its own program, not the quick one
    assert np.array_equal(quick.run_of, default.run_of) and np.array_equal(quick.run_params, default.run_params)


def test_run_r_is_keyed_by_fold_in_of_the_seed_whatever_the_number_of_runs(sd1):
    """Run r's key is `fold_in(PRNGKey(seed), r)`, folded inside the compiled program: a run's
    bits do not depend on how many runs are made, another seed
    gives other runs, and the keys are `runner.fold_keys`'."""
    from dcjax.fitting.runner import fold_keys

    one, three = (dcjax.fit(sd1, search=dcjax.Search(runs=n, budget=700, seed=5)) for n in (1, 3))
    assert np.array_equal(one.run_params[0], three.run_params[0]) and one.run_of[0] == three.run_of[0]
    assert len(set(map(float, three.run_of))) == 3  # three different runs
    assert not np.array_equal(dcjax.fit(sd1, search=dcjax.Search(runs=1, budget=700, seed=6)).run_params[0], one.run_params[0])
    inside = jax.jit(lambda seed, ids: jax.vmap(lambda r: jax.random.fold_in(jax.random.PRNGKey(seed), r))(ids))
    np.testing.assert_array_equal(np.asarray(inside(np.int64(5), np.arange(3))), np.asarray(fold_keys(5, 3)))


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/maps").is_file(), reason="needs Linux /proc")
def test_repeated_fits_do_not_accumulate_memory_mappings(sd1, monkeypatch):
    """Each compiled executable holds memory mappings; a long sweep of fits must not
    keep them all (the kernel limit, vm.max_map_count, ended a full reproduction once)."""

    def maps():
        return sum(1 for _ in open("/proc/self/maps"))

    cache = sys.modules["dcjax.fitting.runs"].EXECUTABLES
    cache.clear()  # the same start whatever ran before (the cache holds `cache.size` executables)
    monkeypatch.setattr(cache, "size", 1)  # fills after one call: four more show whether evicted ones are freed
    methods = ["de-rand-1-exp", "tlbo", "abc", "ga", "de-best-1-bin"]
    counts = []
    gc.disable()  # the eviction itself must free them, not a collection that happens to run
    try:
        for k in range(cache.size + 4):  # distinct executables: the cache fills, then evicts
            fit(sd1, search=dcjax.Search(make_strategy(methods[k % 5], pop_size=70 - k // 5), runs=1, budget=140, seed=k))
            counts.append(maps())
    finally:
        gc.enable()
    full = cache.size - 1
    assert counts[-1] - counts[full] < 200, counts  # were the executables kept: ~100 more per call


@pytest.mark.slow
def test_progress_reports_and_changes_nothing(sd1, tmp_path, capsys):
    """Chunked runs (progress) give the same bits as one compiled run, memory or not; the CLI's
    --progress draws a bar on stderr."""
    for memory in (None, "stma"):
        kw = dict(runs=3, budget=2800, seed=4, memory=None if memory is None else dcjax.MEMORIES[memory])
        seen = []
        a, b = fit(sd1, **kw), fit(sd1, progress=seen.append, **kw)
        for f in ("run_of", "run_params", "fes", "iterations"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        np.testing.assert_array_equal(a.history, b.history)
        assert seen == sorted(seen) and seen[-1] == 1.0 and (memory is not None or len(seen) >= 10)
        assert not sys.modules["dcjax.fitting.runs"]._METERS  # a meter lives for its call only
    assert main(["fit", "SD1", "--runs", "1", "--budget", "1400", "--progress", "--out", str(tmp_path)]) == 0
    assert "iterations (all runs)" in capsys.readouterr().err


def test_a_sweep_over_f_and_cr_reuses_one_executable(sd1):
    """DE's F and CR are arguments of the compiled runs (`Strategy.traced`), not constants: another
    F or CR runs the same executable, and gives other runs; the same F gives the same bits."""
    kw = dict(runs=2, budget=2100, seed=1)
    a = fit(sd1, **kw, search=dcjax.Search(make_strategy("de-rand-1-exp", f=0.5, cr=0.9)))
    b = fit(sd1, **kw, search=dcjax.Search(make_strategy("de-rand-1-exp", f=0.7, cr=0.6)))
    c = fit(sd1, **kw, search=dcjax.Search(DERand1Exp(f=0.5, cr=0.9)))
    assert b.timing["reused_executable"] and c.timing["reused_executable"]
    assert not np.array_equal(a.run_params, b.run_params)
    np.testing.assert_array_equal(a.run_params, c.run_params)
    assert "f=0.7" in b.settings["strategy"] and "cr=0.6" in b.settings["strategy"]
