"""The search where none is asked for (`dcjax.Search.for_steps`), on the command line and in
`dcjax.fit(search=None)`: the paper's method, runs and budget ending each run once it has
converged for one recording, `--each` and a short joint fit; a short CMA-ES search for a joint fit
of many recordings; the paper's fixed budget for the paper's data (a sidecar naming Table 4 or 8);
a flag that is given always wins; the 0.3 keywords of `fit` still work, with a warning, and give
the same bits."""

import dataclasses

import numpy as np
import pytest

import dcjax
from dcjax.cli.fit_command import FitCommand
from dcjax.cli.parser import build_parser
from dcjax.fitting.search import MANY_STEPS, Search, search_of

PAPER_SEARCH, OWN_SEARCH, MANY_SEARCH = Search.paper(), Search.own(), Search.many()


def recordings(n: int, samples: int) -> list[dcjax.Recording]:
    t = 1e-4 * np.arange(samples)
    return [dcjax.Recording(t=t, u_a=np.ones_like(t), i_a=np.ones_like(t), omega=np.ones_like(t), name=f"r{k}") for k in range(n)]


def command(argv: list[str]) -> FitCommand:
    args = build_parser().parse_args(["fit", "a.csv", *argv])
    args.cleanup = None
    return FitCommand.of(args)


def search_for(c: FitCommand, recs) -> Search:
    """The search `dcjax.fit` runs for the command's changes (`search_of` over `Search.for_steps`)."""
    steps = sum(len(r.t) for r in recs) * getattr(c.integrator, "substeps", 1) if len(recs) > 1 else 0
    return search_of(c.search, {}, Search.for_steps(steps))


def chosen(argv: list[str], recs) -> tuple:
    search = search_for(command(argv), recs)
    return search.name, search.runs, search.budget, type(search.strategy).__name__, search.stop


def test_a_joint_fit_of_many_samples_gets_the_short_search():
    many = recordings(4, MANY_STEPS // 4)
    assert chosen([], many) == ("de-best-1-bin", MANY_SEARCH.runs, MANY_SEARCH.budget, "DEBest1Bin", dcjax.Converged())
    assert MANY_SEARCH.strategy.pop_size == 30 and MANY_SEARCH.runs == 1
    assert chosen(["--nd", "2"], recordings(4, MANY_STEPS // 8)) == chosen([], many)  # sub-steps count
    assert Search.for_steps(MANY_STEPS - 1) == OWN_SEARCH and MANY_SEARCH.budget * MANY_SEARCH.runs < PAPER_SEARCH.budget
    assert dataclasses.replace(OWN_SEARCH, stop=None) == PAPER_SEARCH  # the paper's search, stopping on convergence


@pytest.mark.parametrize("recs", [recordings(1, 2 * MANY_STEPS), recordings(3, 501), []], ids=["one long", "short joint", "each"])
def test_otherwise_the_papers_search_stopping_on_convergence(recs):
    assert chosen([], recs) == (PAPER_SEARCH.method, PAPER_SEARCH.runs, PAPER_SEARCH.budget, "DERand1Exp", dcjax.Converged())


def test_a_given_flag_wins_and_the_rest_follow_the_size():
    many = recordings(2, MANY_STEPS)
    assert chosen(["--runs", "3"], many) == ("de-best-1-bin", 3, MANY_SEARCH.budget, "DEBest1Bin", MANY_SEARCH.stop)
    assert chosen(["--method", "tlbo", "--generations", "5"], many)[:3] == ("tlbo", MANY_SEARCH.runs, MANY_SEARCH.budget)
    assert search_for(command(["--generations", "5"]), many).generations == 5
    assert chosen(["--budget", "900"], recordings(2, 100)) == (PAPER_SEARCH.method, PAPER_SEARCH.runs, 900, "DERand1Exp", OWN_SEARCH.stop)
    assert chosen(["--stop", "never"], many)[-1] is None and chosen(["--stop", "patience=7"], many)[-1] == dcjax.Converged(patience=7)


def test_the_papers_data_keep_the_papers_fixed_budget():
    """A fit of recordings whose sidecars name Table 4 or 8 (the embedded SD*/MD*) runs the paper's
    search, every run spending its budget, where no stopping rule is asked for; one's own data,
    or the paper's data with `stop` given, run the rule; the result records what ran."""
    sd1 = dcjax.datasets.load("SD1").select(slice(0, 201))
    own = sd1.replace(name="own", metadata={k: v for k, v in sd1.metadata.items() if k != "bounds"})
    assert sd1.metadata["bounds"] == "table4" and "bounds" not in own.metadata
    few, loose = {"runs": 1, "budget": 2800}, {"runs": 1, "budget": 100_000, "stop": dcjax.Converged(rtol=1e-3, atol=1e-5, patience=10)}
    paper = dcjax.fit(sd1, params="table4", search=few)
    mine, asked = dcjax.fit(own, params="table4", search=loose), dcjax.fit(sd1, params="table4", search=loose)
    assert paper.search.stop is None and paper.run_status == (dcjax.RunStatus.BUDGET,)
    assert mine.search.stop == asked.search.stop == dcjax.Converged(rtol=1e-3, atol=1e-5, patience=10).spec()
    assert mine.run_status == asked.run_status == (dcjax.RunStatus.CONVERGED,)
    default = dcjax.fitting.planning.plan("dc", few)
    assert default.default_stop and default.search.stop == dcjax.Converged()
    for_data = dcjax.fitting.sets.for_data
    assert for_data(default, [[own]]).search.stop == dcjax.Converged() and for_data(default, [[sd1], [own]]) is default
    assert for_data(default, [[sd1]]).search == Search.paper(**few)
    assert not dcjax.fitting.planning.plan("dc", {"stop": None}).default_stop


def test_fit_resolves_its_search_from_the_problem_and_takes_the_old_keywords():
    """`dcjax.fit(search=None)` of a joint fit of many samples runs `Search.many()` and records it;
    `runs=`, `budget=`, ... of 0.3 warn and give the bits of the `Search` they spell."""
    many = [r.replace(u_a=np.linspace(0, 1, len(r)), i_a=np.linspace(0, 2, len(r)), omega=np.linspace(0, 3, len(r)))
            for r in recordings(4, MANY_STEPS // 4)]  # fmt: skip
    plan = dcjax.fitting.planning.plan  # what fit hands the engine, without running it
    seen = {}

    def spy(p, setups, progress=None):
        seen["search"] = p.search
        raise RuntimeError("stop here")

    import dcjax.fitting.sets as sets_module

    original = sets_module.fit_setups
    sets_module.fit_setups = spy
    try:
        with pytest.raises(RuntimeError, match="stop here"):
            dcjax.fit(many, params="table4")
        assert seen.pop("search") == Search.many()  # table4 given, no sidecar: not the paper's data
        with pytest.raises(RuntimeError, match="stop here"):
            dcjax.fit(many, params="table4", search={"runs": 3, "generations": 4})  # changes to the default
        assert seen["search"] == Search.many(runs=3).with_generations(4)
    finally:
        sets_module.fit_setups = original
    assert plan is dcjax.fitting.planning.plan
    with pytest.raises(ValueError, match="search: unknown field.s. rums; changes to the default take method, runs"):
        dcjax.fit(many, params="table4", search={"rums": 3})
    sd1 = dcjax.datasets.load("SD1").select(slice(0, 201))
    with pytest.warns(DeprecationWarning, match=r"fit's runs=, budget= is deprecated since dcjax 0.4; use search=dcjax.Search"):
        old = dcjax.fit(sd1, params="table4", runs=1, budget=700)
    new = dcjax.fit(sd1, params="table4", search=Search(runs=1, budget=700))
    np.testing.assert_array_equal(old.run_params, new.run_params)
    with pytest.raises(ValueError, match="unknown argument"):
        dcjax.fit(sd1, params="table4", rums=1)


def test_each_run_says_how_it_ended():
    """`FitResult.run_status` and result.json's runs[].status: the budget spent, the iteration
    limit reached, no finite objective."""
    sd1 = dcjax.datasets.load("SD1").select(slice(0, 201))
    limited = dcjax.fit(sd1, params="table4", search=Search(dcjax.strategies.DERand1Exp(generations=3), runs=1, budget=1400))
    spent = dcjax.fit(sd1, params="table4", search=Search(runs=2, budget=140))
    params = dcjax.DC().parameters("table4")
    params["La"].set(value=0.0, vary=False)  # every simulation divides by zero
    broken = dcjax.fit(sd1, params=params, search=Search(runs=1, budget=140))
    assert limited.run_status == (dcjax.RunStatus.GENERATIONS,) and spent.run_status == (dcjax.RunStatus.BUDGET,) * 2
    assert broken.run_status == (dcjax.RunStatus.NON_FINITE,) and not broken.success
    assert [r["status"] for r in broken.to_dict()["runs"]] == ["non-finite"]
