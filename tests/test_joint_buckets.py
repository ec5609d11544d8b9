"""A joint fit's recordings of far lengths padded into length buckets where the search is short
(`dcjax.simulation.joint.joint_buckets`, called by `dcjax.fitting.runs.bucketed`): one scan to
compile instead of one per length, the same OF to rounding, the truth of the reference's data."""

import sys

import numpy as np
import pytest
import test_matrix as matrix

import dcjax
from dcjax.simulation.joint import PAD_SHARE, joint_buckets, joint_problem


def _problems(model_key: str, lengths_key: str):
    recs, _ = matrix.data(model_key, lengths_key, "plain")
    integrator = None if matrix.CASES[model_key].discrete else dcjax.RK4(substeps=4)
    return [dcjax.make_problem(r, integrator, model=matrix.CASES[model_key].model) for r in recs]


def test_far_lengths_share_a_bucket_where_the_search_is_short_and_keep_a_scan_each_where_it_is_long():
    far = _problems("dc", "far")
    lengths = [p.n for p in far]
    assert lengths == [240, 120] and max(lengths) * 2 > PAD_SHARE * sum(lengths)  # too far apart for `groups` alone
    assert joint_problem(far).groups() == [(0,), (1,)]
    short = joint_buckets(far, fes=2 * 700, compile_fes=1e9)  # 2 runs x 700 FEs: 120 padded samples cost 1.7e5 FEs
    assert [p.n for p in short] == [240, 240] and all(p.mask is not None for p in short)
    np.testing.assert_array_equal(np.asarray(short[1].mask), np.r_[np.ones(120), np.zeros(120)])
    assert joint_problem(short).groups() == [(0, 1)]
    x = np.array([matrix.CASES["dc"].truth[n] for n in dcjax.DC.names]) * np.random.default_rng(0).uniform(0.9, 1.1, (5, 7))
    unpadded, padded_ = (np.asarray(joint_problem(ps, (0.6, 0.4)).objective(x)) for ps in (far, short))
    np.testing.assert_allclose(padded_, unpadded, rtol=1e-13)
    assert joint_buckets(far, fes=1e8, compile_fes=1e9) == far  # a long search: 120 padded samples would cost 1.2e10 FEs
    close = _problems("dc", "close")
    assert joint_buckets(close, fes=1.0, compile_fes=1e9) == close  # one scan already (`PAD_SHARE`)
    discrete = _problems("discrete", "far")
    assert joint_buckets(discrete, fes=1.0, compile_fes=1e9) == discrete  # a map is not paddable


def test_a_short_joint_fit_of_far_lengths_runs_one_padded_scan_and_recovers_the_truth(monkeypatch):
    runs = sys.modules["dcjax.fitting.runs"]
    seen = []
    wrapped = runs.joint_buckets
    monkeypatch.setattr(
        runs, "joint_buckets", lambda problems, fes, compile_fes: seen.append(wrapped(problems, fes, compile_fes)) or seen[-1]
    )
    res, truth = matrix.fit_cell("dc", "far", "plain")
    assert [p.n for p in seen[0]] == [240, 240]
    err = matrix.errors(res, truth)
    assert max(err.values()) <= matrix.TOL, err
    x = np.array([res.best_values[n] for n in dcjax.DC.names])
    problems = _problems("dc", "far")
    assert res.of == pytest.approx(float(joint_problem(problems, res.joint_weights).objective(x)), rel=1e-12)
