"""The stopping rule (`dcjax.Converged` in `Search.stop`): a converged run ends before its budget,
with its reason in the result, result.json, the report and the command line; a rule that never
fires changes no bit; the rule's values are checked."""

import json

import numpy as np
import pytest

import dcjax
from dcjax.cli import main
from dcjax.strategies.loop import has_converged
from dcjax.strategies.stopping import Converged

METHODS = ["de-rand-1-exp", "de-best-1-bin", "tlbo", "ga", "abc", "cma-es"]
FAST = "de-rand-1-exp"
EARLY = Converged(rtol=1e-3, atol=1e-5, patience=10)  # loose: every method converges on SD1 well within the budget


@pytest.fixture(scope="module")
def sd1():
    return dcjax.datasets.load("SD1").select(slice(0, 201))


def _marks(method: str):
    return [] if method == FAST else [pytest.mark.slow]


@pytest.mark.parametrize("method", [pytest.param(m, marks=_marks(m)) for m in METHODS])
def test_a_converged_run_ends_before_its_budget_and_says_so(sd1, method, tmp_path):
    budget = 100_000
    res = dcjax.fit(sd1, params="table4", search=dcjax.Search(method, runs=2, budget=budget, stop=EARLY))
    assert res.run_status == (dcjax.RunStatus.CONVERGED,) * 2
    assert np.all(res.fes < budget) and res.converged is not None and res.converged.all()
    assert res.search.stop == {"rtol": 1e-3, "atol": 1e-5, "patience": 10}
    res.to_json(tmp_path / "result.json")
    assert [r["status"] for r in json.loads((tmp_path / "result.json").read_text())["runs"]] == ["converged"] * 2
    back = dcjax.load_result(tmp_path / "result.json", [sd1])
    assert back.run_status == res.run_status and back.search.stop == res.search.stop
    assert f"converged          = 2/2 runs after {float(np.mean(res.fes)):,.0f} of 100,000 FEs" in back.report()


@pytest.mark.parametrize("method", [pytest.param(m, marks=_marks(m)) for m in METHODS])
def test_a_rule_that_never_fires_changes_no_bit(sd1, method):
    """The loop's body is the same with a rule; only its condition asks it: same bits where it
    never fires (a patience longer than the run)."""
    plain = dcjax.fit(sd1, params="table4", search=dcjax.Search(method, runs=2, budget=1400))
    ruled = dcjax.fit(sd1, params="table4", search=dcjax.Search(method, runs=2, budget=1400, stop=Converged(patience=10**6)))
    for field in ("run_params", "run_of", "fes", "iterations"):
        np.testing.assert_array_equal(getattr(plain, field), getattr(ruled, field))
    np.testing.assert_array_equal(plain.history, ruled.history)
    assert plain.converged is None and not ruled.converged.any()  # pyright: ignore[reportOptionalMemberAccess]
    assert ruled.run_status == plain.run_status == (dcjax.RunStatus.BUDGET,) * 2


@pytest.mark.filterwarnings("error::RuntimeWarning")  # NumPy arrays of inf: no "invalid value encountered in subtract"
def test_the_population_must_agree_for_the_des_but_not_for_ga():
    """Stagnation alone ends GA and ABC; the DEs, TLBO and CMA-ES also need half their
    population's OFs within the tolerance of the best (a stalled best over a spread population
    goes on; one member stuck far off does not keep it going)."""
    history = np.array([3.0, 2.0, 1.0, 1.0, 1.0, 1.0, np.nan])
    spread = np.array([1.0, 5.0])
    rule = Converged(rtol=0.0, atol=1e-9, patience=3)
    assert bool(has_converged(rule, np.int64(6), history, spread, spread=False))
    assert not bool(has_converged(rule, np.int64(6), history, spread, spread=True))
    assert bool(has_converged(rule, np.int64(6), history, np.array([1.0, 1.0]), spread=True))
    assert bool(has_converged(rule, np.int64(6), history, np.array([1.0, 1.0, 5.0]), spread=True))
    assert not bool(has_converged(rule, np.int64(3), history, spread, spread=False))  # fewer iterations than the patience
    assert not bool(has_converged(rule, np.int64(6), np.full(7, np.inf), spread, spread=False))  # nothing finite: never
    assert not dcjax.strategies.GA.population_converges and dcjax.strategies.DERand1Exp.population_converges


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"rtol": -1.0}, "Converged.rtol must be a finite number >= 0"),
        ({"atol": float("inf")}, "Converged.atol must be a finite number >= 0"),
        ({"patience": 0}, "Converged.patience must be a positive integer"),
        ({"patience": 2.5}, "Converged.patience must be a positive integer"),
    ],
)
def test_the_rule_checks_its_values(kwargs, message):
    with pytest.raises(dcjax.ConfigError, match=message):
        Converged(**kwargs)


def test_search_takes_a_rule_only(sd1):
    with pytest.raises(dcjax.ConfigError, match="Search.stop must be None or dcjax.Converged"):
        dcjax.Search(stop="converged")  # pyright: ignore[reportArgumentType]
    assert dcjax.Search.many(stop=EARLY).stop == EARLY


def test_the_command_line_stops_on_convergence(tmp_path, capsys):
    argv = "fit SD1 --method ga --runs 1 --budget 30000 --stop rtol=1e-3,atol=1e-5,patience=10 --plots none --out".split()
    rc = main([*argv, str(tmp_path / "o")])
    out = capsys.readouterr().out
    assert rc == 0 and "converged: 1/1 runs after " in out and "of 30,000 FEs (mean; rtol 0.001, atol 1e-05, patience 10)" in out
    d = json.loads((tmp_path / "o" / "result.json").read_text())
    assert d["runs"][0]["status"] == "converged" and d["settings"]["stop"] == {"rtol": 0.001, "atol": 1e-05, "patience": 10}
    assert main(["fit", "SD1", "--stop", "tol=1"]) == 2
    assert capsys.readouterr().err.strip() == "dcjax: error: --stop takes rtol, atol and patience, got tol"
