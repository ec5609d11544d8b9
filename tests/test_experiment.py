"""Issue 28: the loss, the initial state, per-recording (local) parameters, sensor offsets and
input delays, in `fit`, the CLI, result.json, `report`, `validate` and `simulate`. Data are
generated with `dcjax.simulate` (noise-free), references are computed by hand in NumPy."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import cli
from dcjax.fitting.observation import Observation, derivative_at_start
from dcjax.fitting.outcome import recorded
from dcjax.fitting.planning import plan
from dcjax.fitting.search import Search
from dcjax.io.numpy_simulator import simulate_numpy
from dcjax.simulation.losses import L1, SSE, Huber, get_loss

M = dcjax.DC()


@pytest.fixture(scope="module")
def sd1():
    return dcjax.datasets.load("SD1")


@pytest.fixture(scope="module")
def truth(sd1):
    return dict(sd1.metadata["true_params"])


def _generated(base, p, name, adjustments=None, start=(0.0, 0.0)):
    """A noise-free recording of the paper's motor with `base`'s time and input."""
    prob = dcjax.make_problem(base, model=M, initial={"i_a": start[0], "omega": start[1]})
    y = np.asarray(dcjax.simulate(p, prob, adjustments))
    return base.replace(channels={**base.channels, "i_a": y[:, 0], "omega": y[:, 1]}, name=name, metadata={"true_params": dict(p)})


def test_the_default_loss_is_eq_24_bit_for_bit(sd1, truth):
    """SSE over the peak: the objective of a problem made with `loss=SSE()` is the default's bits."""
    x = jnp.asarray([truth[n] for n in M.names]) * 1.01
    a = dcjax.objective(x, dcjax.make_problem(sd1))
    b = dcjax.objective(x, dcjax.make_problem(sd1, loss=SSE()))
    assert float(a) == float(b) and float(a) > 0


def test_l1_unnormalised_is_the_pooled_mean_absolute_error_by_hand(sd1, truth):
    """Done when (e): `--loss l1 --normalize none` over two recordings of different lengths equals
    the mean absolute error pooled over every sample of both, per channel, summed over channels,
    with the trajectories of the plain NumPy simulator."""
    other = sd1.replace(t=sd1.t[:301], channels={k: v[:301] * (1.0 + 0.01 * (k != "u_a")) for k, v in sd1.channels.items()}, name="b")
    recs = [sd1, other]
    x = np.array([truth[n] for n in M.names]) * np.array([1.02, 0.97, 1.01, 1.03, 0.9, 1.1, 1.0])
    setup = plan(M, observation=Observation(get_loss("l1", "none"))).setup(recs, "table4")
    got = float(setup.target.objective(jnp.asarray(x)))
    by_hand = 0.0
    for j, c in enumerate(M.outputs):
        errs = []
        for r in recs:
            sim = simulate_numpy(x, r.t, r.u_a, r.i_a[0], r.omega[0])
            errs.append(np.abs(sim[:, j] - r[c]))
        by_hand += np.concatenate(errs).mean()
    assert got == pytest.approx(by_hand, rel=1e-12)
    assert setup.joint_weights == pytest.approx([501 / 802, 301 / 802])
    pooled = dcjax.fit(recs, M, "table4", search=dcjax.Search(runs=1, budget=140), observation=dcjax.Observation(loss=L1(normalize="none")))
    assert pooled.settings["joint_weights"] == pytest.approx([501 / 802, 301 / 802])
    x = jnp.asarray([pooled.best_values[n] for n in pooled.names])
    assert float(pooled.target().objective(x)) == pytest.approx(pooled.of, rel=1e-12)


def test_huber_is_sse_within_delta_and_linear_beyond():
    h = Huber(delta=0.5)
    a = jnp.asarray([-2.0, -0.5, 0.1, 0.4, 3.0])
    np.testing.assert_allclose(h.rho(a), [2 * 0.5 * 2 - 0.25, 0.25, 0.01, 0.16, 2 * 0.5 * 3 - 0.25])
    r = h.residual(a, 1.0, 1.0)
    np.testing.assert_allclose(r**2, h.rho(a))
    assert get_loss("huber:0.5") == h and get_loss("L1", "none") == L1(normalize="none")


@pytest.mark.parametrize("spec", ["l2", "huber", "huber:-1", "huber:x", "l1:3"])
def test_a_bad_loss_is_one_line(spec):
    with pytest.raises(ValueError, match="loss"):
        get_loss(spec)


@pytest.mark.slow
def test_local_parameters_joint_fit_recovers_each_load(tmp_path, sd1, truth, capsys):
    """Done when (a): one motor under three loads, `--local Tla`: Ra, La, cm, J and each Tla to
    1e-6, the report lists the three; equal-length recordings go through one vmapped objective."""
    files = []
    for k, tla in enumerate([0.005, 0.01, 0.02]):
        rec = _generated(sd1, dict(truth, Tla=tla), f"load{k}", start=(sd1.i_a[0], sd1.omega[0]))
        files.append(tmp_path / f"load{k}.csv")
        dcjax.save_csv(rec, files[-1])
    out = tmp_path / "fit"
    argv = ["fit", *map(str, files), "--local", "Tla", "--bounds", "table4", "--runs", "4", "--budget", "30000", "--polish"]
    assert cli.main([*argv, "--out", str(out)]) == 0
    d = json.loads((out / "result.json").read_text())
    for n in ("Ra", "La", "cm", "J"):
        assert d["params"][n] == pytest.approx(truth[n], rel=1e-6), n
    for k, tla in enumerate([0.005, 0.01, 0.02]):
        assert d["params"][f"Tla[{k}]"] == pytest.approx(tla, rel=1e-6)
    assert d["settings"]["local"] == ["Tla"] and d["parameters"]["Tla[1]"]["local"] is True
    capsys.readouterr()
    assert cli.main(["report", str(out / "result.json")]) == 0
    text = capsys.readouterr().out
    assert all(f"Tla[{k}]:" in text and f"(load{k})" in text for k in range(3))
    res = dcjax.load_result(out / "result.json")
    assert res.values(2)["Tla"] == pytest.approx(0.02, rel=1e-6) and res.values(0)["Ra"] == d["params"]["Ra"]


@pytest.mark.slow
def test_a_fitted_initial_state_of_an_unmeasured_state(sd1, truth):
    """`initial={"omega": "fit"}` for a model that measures only the current: the speed the
    recording started at is found (y0_omega), where the default starts it at 0 with a note."""

    class CurrentOnly(dcjax.DC):
        measured = ("i_a",)

    model = CurrentOnly()
    full = _generated(sd1, truth, "spinning", start=(0.0, 40.0))
    rec = full.replace(channels={"u_a": full.u_a, "i_a": full.i_a})
    params = model.parameters("table4")
    for n in model.names:
        if n != "Ra":
            params[n].set(value=truth[n], vary=False)
    with pytest.raises(ValueError, match=r"params\['y0_omega'\]\.set\(min=LO, max=HI\)"):  # an unmeasured state has no automatic range
        dcjax.fit(rec, model, params, search=dcjax.Search(runs=1, budget=700), observation=dcjax.Observation(initial={"omega": "fit"}))
    params = dcjax.Parameters([*params.values(), dcjax.Parameter("y0_omega", min=0.0, max=100.0)])
    res = dcjax.fit(
        rec, model, params, search=dcjax.Search(runs=2, budget=2000, polish=True), observation=dcjax.Observation(initial={"omega": "fit"})
    )
    assert res.names == (*model.names, "y0_omega")
    assert res.best_values["y0_omega"] == pytest.approx(40.0, rel=1e-6) and res.best_values["Ra"] == pytest.approx(truth["Ra"], rel=1e-6)
    notes = Observation().notes(model, [rec])
    assert len(notes) == 1 and "omega" in notes[0] and "starts at 0" in notes[0]


def test_initial_specs(sd1):
    obs = Observation(initial={"omega": 3.0}).check(M)
    assert obs.initial_values(M, sd1) == {"i_a": float(sd1.i_a[0]), "omega": 3.0}
    t = np.linspace(0, 1, 1001)
    rec = dcjax.Recording(t=t, q=np.sin(2 * np.pi * t), name="pos")
    assert derivative_at_start(rec, "q") == pytest.approx(2 * np.pi, rel=2e-2)
    for bad, match in [({"theta": 1.0}, "unknown state"), ({"omega": "guess"}, "number, measured, smoothed, derivative or fit"),
                       ({"omega": "derivative"}, "derivative_of")]:  # fmt: skip
        with pytest.raises(ValueError, match=match):
            Observation(initial=bad).check(M)


@pytest.mark.parametrize(
    "extra,match",
    [
        (["--const", "kp"], "--const"),
        (["--initial", "omega=sideways"], "number, measured, smoothed, derivative or fit"),
        (["--initial", "theta=0"], "unknown state 'theta'"),
        (["--local", "Tla"], "--local needs a joint fit"),
        (["--local", "Rx", "SD2"], "local: unknown parameter Rx"),
        (["--offset", "u_a"], "offset: u_a is not a measured channel"),
        (["--delay", "i_a"], "delay: i_a is not an input"),
        (["--loss", "l3"], "loss must be sse, l1 or huber:DELTA"),
        (["--loss", "huber:0"], "delta must be a positive number"),
        (["--loss", "l1", "--polish"], "polish: Levenberg-Marquardt needs a least-squares loss"),
        (["--bound", "offset_omega=0:1"], "unknown parameter(s) offset_omega"),
    ],
)
def test_bad_experiment_options_are_one_line(tmp_path, capsys, extra, match):
    more = [a for a in extra if a == "SD2"]
    extra = [a for a in extra if a != "SD2"]
    rc = cli.main(["fit", "SD1", *more, *extra, "--runs", "1", "--budget", "700", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and match in err and err.count("\n") == 1, err


def test_equal_length_recordings_share_one_vmapped_objective(sd1, truth):
    """A joint fit of equal-length recordings evaluates them stacked (one scan, one compile); the
    OF is the bits of the recordings' objectives summed one by one, with local parameters too."""
    from dcjax.simulation.joint import JointProblem, Layout, joint_problem

    recs = [_generated(sd1, dict(truth, Tla=0.005 * (k + 1)), f"r{k}") for k in range(3)]
    probs = [dcjax.make_problem(r) for r in recs]
    x = jnp.asarray([[truth[n] * (1 + 0.01 * k) for n in M.names] for k in range(5)])
    target = joint_problem(probs)
    assert target.groups() == [(0, 1, 2)]
    by_hand = 0 + sum(w * dcjax.objective(x, p) for w, p in zip(target.weights, probs))
    np.testing.assert_array_equal(target.objective(x), by_hand)
    cols = tuple((0, 1, 2, 3, 4 + r, 7, 8) for r in range(3))  # Tla local: columns 4, 5, 6
    local = JointProblem(tuple(probs), target.weights, Layout(("Ra", "La", "cm", "J", "Tla[0]", "Tla[1]", "Tla[2]", "Tlb", "Tlc"), cols))
    xl = jnp.concatenate([x[:, :4], x[:, 4:5] * jnp.asarray([1.0, 2.0, 4.0]), x[:, 5:]], axis=1)
    want = sum(w * dcjax.objective(xl[:, list(c)], p) for w, p, c in zip(target.weights, probs, cols))
    np.testing.assert_array_equal(local.objective(xl), 0 + want)


@pytest.mark.slow  # > 4 s: the full run's
def test_a_stacked_target_gives_the_same_bits_from_a_program_that_does_not_grow(sd1, truth, monkeypatch):
    """`stacked_target`: a joint problem of one group (equal lengths; close ones padded) held
    stacked gives the JointProblem's OF to the bit (and its residuals, the polish's), and its compiled objective does not grow with
    the number of recordings (a JointProblem's stacks and splits them inside: 476 servo logs
    compiled 4.7 s, and 22.7 s over two devices, against 2.4 s and 2.6 s stacked); beyond
    `UNROLLED_SUM` recordings the weighted sum is a loop: the same OF to rounding, both paths
    alike to the bit, and not even the sum's terms grow."""
    import jax

    import dcjax.simulation.joint as joint
    from dcjax.simulation.joint import StackedJoint, joint_problem, stacked_target

    def problems(n):
        return [dcjax.make_problem(_generated(sd1, dict(truth, Tla=0.005 * (k + 1)), f"r{k}")) for k in range(n)]

    of = jax.jit(lambda t, x: t.objective(x))  # compiled, as the runs evaluate it
    x = jnp.asarray([[truth[n] * (1 + 0.01 * k) for n in M.names] for k in range(5)])
    close = sd1.replace(t=sd1.t[:480], channels={c: v[:480] for c, v in sd1.channels.items()}, name="close")
    for probs in (problems(3), [*problems(2), dcjax.make_problem(close)]):
        target = joint_problem(probs, [0.2, 0.3, 0.5])
        held = stacked_target(target)
        assert isinstance(held, StackedJoint) and target.groups() == [(0, 1, 2)]
        np.testing.assert_array_equal(of(held, x), of(target, x))
        r_held, r_joint = held.residuals(x[1]), target.residuals(x[1])  # the polish's: the same rows, padding as zeros
        np.testing.assert_array_equal(r_held[r_held != 0], r_joint[r_joint != 0])
        np.testing.assert_allclose(r_held @ r_held, of(target, x)[1], rtol=1e-12)
    size = lambda t: len(of.lower(t, x).as_text())
    few, many = joint_problem(problems(2)), joint_problem(problems(24))
    grows, grows_stacked = size(many) - size(few), size(stacked_target(many)) - size(stacked_target(few))
    assert grows > 2 * grows_stacked, (grows, grows_stacked)  # only the weighted sum's terms remain per recording
    leaves = lambda t: len(jax.tree.leaves(t))
    assert leaves(stacked_target(many)) == leaves(stacked_target(few)) and leaves(many) == 12 * leaves(few)  # the program's arguments
    short = sd1.replace(t=sd1.t[:150], channels={c: v[:150] for c, v in sd1.channels.items()}, name="short")
    mixed = joint_problem([*problems(2), dcjax.make_problem(short)])
    assert stacked_target(mixed) is mixed  # two groups: left as it is
    target = joint_problem(problems(3), [0.2, 0.3, 0.5])
    written = of(stacked_target(target), x)
    monkeypatch.setattr(joint, "UNROLLED_SUM", 2)
    of = jax.jit(lambda t, x: t.objective(x))  # traced again with the loop
    np.testing.assert_array_equal(of(stacked_target(target), x), of(target, x))
    np.testing.assert_allclose(of(target, x), written, rtol=1e-14)
    fewer = joint_problem(problems(16))  # 15 and 23 loop steps: 8 terms an iteration and a rest of 7 alike
    assert abs(size(stacked_target(many)) - size(stacked_target(fewer))) < 50  # only the shapes' digits differ


def test_split_shares_sum_to_the_stacked_objective(sd1, truth):
    """`split_target` into 3 shares of 5 recordings (one padding copy of weight 0), each share's
    objective summed by `psum` over a named axis (here a vmap's; a mesh's `shard_map` in the
    runs): the stacked joint OF to rounding, for a population too."""
    import jax

    from dcjax.simulation.joint import joint_problem, split_target, stacked_target

    probs = [dcjax.make_problem(_generated(sd1, dict(truth, Tla=0.004 * (k + 1)), f"r{k}")) for k in range(5)]
    held = stacked_target(joint_problem(probs, [0.1, 0.3, 0.2, 0.25, 0.15]))
    split = split_target(held, 3, "parts")
    assert list(split.weights) == [0.1, 0.3, 0.2, 0.25, 0.15, 0.0]
    shares = jax.tree.map(lambda a: a.reshape(3, -1, *a.shape[1:]), split)
    x = jnp.asarray([[truth[n] * (1 + 0.01 * k) for n in M.names] for k in range(4)])
    per_share = jax.vmap(lambda t: t.objective(x), axis_name="parts")(shares)
    np.testing.assert_allclose(per_share[0], held.objective(x), rtol=1e-13)
    np.testing.assert_array_equal(per_share[0], per_share[2])  # every share holds the whole sum


def test_mixed_lengths_are_grouped_and_summed_in_order(sd1, truth):
    from dcjax.simulation.joint import joint_problem

    short = sd1.replace(t=sd1.t[:150], channels={c: v[:150] for c, v in sd1.channels.items()}, name="short")
    probs = [dcjax.make_problem(r) for r in (sd1, short, _generated(sd1, dict(truth, Tla=0.02), "b"))]
    target = joint_problem(probs, [0.2, 0.3, 0.5])
    assert target.groups() == [(0, 2), (1,)]
    x = jnp.asarray([[truth[n] * (1 + 0.02 * k) for n in M.names] for k in range(3)])
    np.testing.assert_array_equal(target.objective(x), 0 + sum(w * dcjax.objective(x, p) for w, p in zip(target.weights, probs)))


def test_close_lengths_are_padded_into_one_scan(sd1, truth):
    """Recordings of close lengths are stacked with the shorter ones padded (steps of zero length,
    samples that do not count): the same OF as each recording's own objective, to rounding."""
    from dcjax.simulation.joint import joint_problem, padded

    cut = lambda n: sd1.replace(t=sd1.t[:n], channels={c: v[:n] for c, v in sd1.channels.items()}, name=f"n{n}")
    probs = [dcjax.make_problem(cut(n), loss=loss) for n, loss in ((501, "sse"), (450, "sse"), (480, "sse"))]
    target = joint_problem(probs)
    assert target.groups() == [(0, 1, 2)]
    x = jnp.asarray([[truth[n] * (1 + 0.02 * k) for n in M.names] for k in range(3)])
    alone = [dcjax.objective(x, p) for p in probs]
    np.testing.assert_allclose(target.objective(x), sum(w * a for w, a in zip(target.weights, alone)), rtol=1e-13)
    np.testing.assert_allclose(dcjax.objective(x, padded(probs[1], 501)), alone[1], rtol=1e-13)
    np.testing.assert_allclose(dcjax.residuals(x[0], padded(probs[1], 501))[:450], dcjax.residuals(x[0], probs[1])[:450], rtol=1e-13)


def test_local_offsets_and_the_search_vector_layout(sd1):
    """Offsets may be local, a fitted initial state is one per recording, and the vector's names,
    ranges and columns say so (automatic offset range: +-10 % of the channel's peak)."""
    other = sd1.replace(name="b")
    params = dcjax.Parameters([*M.parameters("table4").values(), dcjax.Parameter("offset_i_a", local=True)])
    setup = plan(M, observation=Observation(initial={"omega": "fit"}, offsets=("i_a",))).setup([sd1, other], params)
    names = setup.space.names
    assert names == (*M.names, "y0_omega[0]", "y0_omega[1]", "offset_i_a[0]", "offset_i_a[1]")
    peak = float(np.max(np.abs(sd1.i_a)))
    assert setup.params["offset_i_a[1]"].max == pytest.approx(0.1 * peak) and setup.params["offset_i_a[0]"].local
    lay = setup.layout
    assert (
        lay.offset_cols == ((9,), (10,)) and lay.y0_cols == ((7,), (8,)) and lay.measured_start == (0,)
    )  # i_a starts at its sample less the offset
    assert recorded(setup, Search(dcjax.strategies.DERand1Exp(), runs=1, budget=700))["local"] == ("offset_i_a", "y0_omega")


@pytest.mark.slow
def test_a_large_joint_fit_splits_each_runs_recordings_over_its_devices():
    """With 4 XLA CPU devices a stacked joint fit above `SPLIT_STEPS` gives each run the devices
    it can (`recording_shards`): one run splits its 5 recordings over 4 (`SplitJoint`, 3 padding
    copies of weight 0), two runs over 2 each (a mesh of runs x recordings); the same search as
    unsplit to rounding (the OF's sum in another order), the same bits again with the same seed,
    and the progress of every run reaches 1."""
    from devices import on_devices

    code = (
        "import json, numpy as np, dcjax, dcjax.fitting.runs as R; from dcjax import datasets;"
        "recs = [datasets.load(n) for n in ('SD1', 'SD2', 'SD3', 'SD4')];"
        "recs.append(recs[0].replace(name='SD1-again', channels={c: 1.01 * v for c, v in recs[0].channels.items()}));"
        "seen = [0.0];"
        "fit = lambda runs, **kw: dcjax.fit(recs, params='table4', search=dcjax.Search('cma-es', runs=runs, budget=1200, seed=2), **kw);"
        "R.SPLIT_STEPS = 0; a, again, c = fit(1), fit(1), fit(2, progress=seen.append); R.SPLIT_STEPS = 1 << 62; b, d = fit(1), fit(2);"
        "out = lambda r: [list(map(float, r.run_of)), np.asarray(r.run_params).tolist()];"
        "print(json.dumps({'devices': [r.timing['devices'] for r in (a, c, b, d)], 'runs': [out(r) for r in (a, again, b, c, d)],"
        "'progress': max(seen)}))"
    )
    res = on_devices(code, 4)
    assert res["devices"] == [4, 4, 1, 4], res
    a, again, b, c, d = res["runs"]
    assert a == again, res  # same seed, same bits
    for split, whole in ((a, b), (c, d)):
        np.testing.assert_allclose(split[0], whole[0], rtol=1e-6)
        np.testing.assert_allclose(split[1], whole[1], rtol=1e-4)
    assert res["progress"] == pytest.approx(1.0)
