"""The command line's search where none is asked for (`dcjax.fitting.defaults`): the paper's for
one recording, `--each` and a short joint fit; a shorter DE/best/1/bin search for a joint fit of many
recordings; a flag that is given always wins."""

import numpy as np
import pytest

import dcjax
from dcjax.cli.args import _parser
from dcjax.cli.fitting import _search
from dcjax.fitting.defaults import MANY_SEARCH, MANY_STEPS, PAPER_SEARCH, search_defaults


def recordings(n: int, samples: int) -> list[dcjax.Recording]:
    t = 1e-4 * np.arange(samples)
    return [dcjax.Recording(t=t, u_a=np.ones_like(t), i_a=np.ones_like(t), omega=np.ones_like(t), name=f"r{k}") for k in range(n)]


def chosen(argv: list[str], recs) -> tuple:
    args = _parser().parse_args(["fit", "a.csv", *argv])
    options = _search(args, recs)
    assert (options["runs"], options["budget"]) == (args.runs, args.budget)
    return args.method, args.runs, args.budget, type(options["method"]).__name__


def test_a_joint_fit_of_many_samples_gets_the_short_search():
    many = recordings(4, MANY_STEPS // 4)
    assert chosen([], many) == (MANY_SEARCH.method, MANY_SEARCH.runs, MANY_SEARCH.budget, "DEBest1Bin")
    assert chosen(["--nd", "2"], recordings(4, MANY_STEPS // 8)) == chosen([], many)  # sub-steps count
    assert search_defaults(MANY_STEPS - 1) == PAPER_SEARCH and MANY_SEARCH.budget * MANY_SEARCH.runs < PAPER_SEARCH.budget


@pytest.mark.parametrize("recs", [recordings(1, 2 * MANY_STEPS), recordings(3, 501), []], ids=["one long", "short joint", "each"])
def test_otherwise_the_papers(recs):
    assert chosen([], recs) == (PAPER_SEARCH.method, PAPER_SEARCH.runs, PAPER_SEARCH.budget, "DERand1Exp")


def test_a_given_flag_wins_and_the_rest_follow_the_size():
    many = recordings(2, MANY_STEPS)
    assert chosen(["--runs", "3"], many) == (MANY_SEARCH.method, 3, MANY_SEARCH.budget, "DEBest1Bin")
    assert chosen(["--method", "tlbo", "--generations", "5"], many)[:3] == ("tlbo", MANY_SEARCH.runs, MANY_SEARCH.budget)
    args = _parser().parse_args(["fit", "a.csv", "--generations", "5"])
    assert _search(args, many)["method"].generations == 5
    assert chosen(["--budget", "900"], recordings(2, 100)) == (PAPER_SEARCH.method, PAPER_SEARCH.runs, 900, "DERand1Exp")
