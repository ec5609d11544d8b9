"""The 0.1 names (`dcjax.compat`): each still works and warns (`DeprecationWarning`), and gives
the bits of the 0.2 call it stands for. Every other test uses the 0.2 API only (pyproject's
filterwarnings makes a 0.1 name an error there)."""

import numpy as np
import pytest

import dcjax
from dcjax import cli, datasets
from dcjax.models.dc import table4, table8

SMALL = dict(runs=2, budget=1400, seed=3)


def _rec(**kw):
    t = np.arange(5) * 0.1
    base = dict(t=t, u_a=np.ones(5), i_a=np.arange(5.0), omega=np.arange(5.0))
    return dcjax.Recording(**{**base, **kw})


def _table4_params():
    params = dcjax.DC().parameters("table4")
    params["Ra"].set(min=10.0, max=60.0, value=40.0)
    params["Tlc"].set(value=8.55e-8, vary=False)
    return params


@pytest.mark.slow  # > 4 s: the full run's
def test_identify_warns_and_gives_the_bits_of_fit(sd1):
    from dcjax.compat import identify

    with pytest.warns(DeprecationWarning, match="dcjax.fit"):
        old = identify(sd1, integrator="euler", nd=2, weights=(1.0, 0.5), bounds={"Ra": (10.0, 60.0)},
                       fixed={"Tlc": 8.55e-8}, x0={"Ra": 40.0}, memory="ltma-s2", **SMALL)  # fmt: skip
    new = dcjax.fit(
        dcjax.with_weights(sd1, {"i_a": 1.0, "omega": 0.5}),
        params=_table4_params(),
        integrator=dcjax.Euler(substeps=2),
        search=dcjax.Search(**SMALL, memory=dcjax.LTMA(order="newest")),
    )
    np.testing.assert_array_equal(old.run_params, new.run_params)
    np.testing.assert_array_equal(old.dups, new.dups)
    with pytest.warns(DeprecationWarning):
        same = identify(sd1, integrator="rk4", nd=2, bounds={"Ra": (10.0, 60.0)}, fixed={"Tlc": 8.55e-8}, x0={"Ra": 40.0}, **SMALL)
    fitted = dcjax.fit(sd1, params=_table4_params(), integrator=dcjax.RK4(substeps=2), search=dcjax.Search(**SMALL))
    np.testing.assert_array_equal(same.run_of, fitted.run_of)
    assert same.params == fitted.params


def test_identify_generations_and_joint_weights(sd1):
    from dcjax.compat import identify

    with pytest.warns(DeprecationWarning):
        r = identify(sd1, runs=2, budget=14_000, memory="stma", generations=150, seed=2)
    assert np.all(r.iterations == 150) and r.settings["generations"] == 150
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="joint_weights"):
        identify([sd1, sd1], joint_weights=[1, 1, 1])
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="generations"):
        identify(sd1, runs=1, budget=700, generations=0)


@pytest.mark.slow
def test_the_cli_flags_give_the_bits_of_identify(tmp_path, capsys):
    from dcjax.compat import identify

    flags = ["--runs", "2", "--budget", "1400", "--seed", "4", "--bounds", "table4", "--bound", "Ra=10:60", "--fix", "Tlc=8.55e-8",
             "--x0", "Ra=40", "--memory", "ltma-s2", "--precision", "Ra=1e-4", "--weights", "1,0.5", "--generations", "12",
             "--integrator", "euler", "--nd", "2"]  # fmt: skip
    assert cli.main(["fit", "SD1", *flags, "--out", str(tmp_path / "cli"), "--no-progress"]) == 0
    capsys.readouterr()
    from_cli = dcjax.load_result(tmp_path / "cli" / "result.json")
    with pytest.warns(DeprecationWarning):
        old = identify(datasets.load("SD1"), integrator="euler", nd=2, weights=(1.0, 0.5), bounds={"Ra": (10.0, 60.0)},
                       fixed={"Tlc": 8.55e-8}, x0={"Ra": 40.0}, memory="ltma-s2", precision={"Ra": 1e-4}, generations=12, runs=2,
                       budget=1400, seed=4)  # fmt: skip
    np.testing.assert_array_equal(from_cli.run_of, old.run_of)
    np.testing.assert_array_equal(from_cli.run_params, old.run_params)
    assert from_cli.best_values == old.best_values


def test_the_01_names_warn_and_are_not_in_all():
    for name in ("identify", "Params", "PARAM_NAMES", "TABLE4", "IdentificationResult", "identify_fleet"):
        assert name not in dcjax.__all__
        with pytest.warns(DeprecationWarning, match=f"dcjax.{name} is deprecated"):
            getattr(dcjax, name)
    with pytest.raises(AttributeError):
        dcjax.no_such_name  # noqa: B018


def test_tables_params_and_bounds_preset():
    from dcjax.compat import PARAM_NAMES, TABLE4, TABLE8, Params, bounds_preset

    np.testing.assert_array_equal(TABLE8.upper, table8().upper)
    np.testing.assert_array_equal(TABLE4.lower, table4().lower)
    assert float(TABLE4.upper[6]) == 1e-6 and float(TABLE8.upper[5]) == 9.55e-2
    with pytest.raises(ValueError, match="unknown bounds preset"):
        bounds_preset("table5")
    np.testing.assert_array_equal(bounds_preset("TABLE8").upper, TABLE8.upper)
    p = Params.from_dict(datasets.true_params("SD1"))
    assert p.to_dict() == datasets.true_params("SD1") and PARAM_NAMES == dcjax.DC.names
    np.testing.assert_array_equal(dcjax.simulate(p, dcjax.make_problem(datasets.load("SD1"))),
                                  dcjax.simulate(datasets.true_params("SD1"), dcjax.make_problem(datasets.load("SD1"))))  # fmt: skip
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="6 entries but model dc has 7"):
        from dcjax.compat import identify

        identify(_rec(), bounds=dcjax.Bounds(np.zeros(6), np.ones(6)), runs=1, budget=70)


def test_the_01_keywords_removed_in_03_are_clear_errors(sd1):
    """The 0.1 keywords of the package's functions warned through 0.2 and are gone in 0.3 (the 0.1
    entry points stay here, in dcjax.compat): each is a clear error naming what is accepted."""
    with pytest.raises(ValueError, match="i_a_limit=3.5: a keyword of Recording is a channel.*limit="):
        _rec(i_a_limit=3.5)
    with pytest.raises(ValueError, match="column 'i_a_limit' must be one-dimensional"):
        _rec().replace(i_a_limit=2.0)
    assert not hasattr(_rec(limit=3.5), "i_a_limit") and _rec(limit=3.5).limit == 3.5
    with pytest.raises(TypeError, match="nd"):
        dcjax.make_problem(sd1, nd=2)  # pyright: ignore[reportCallIssue]
    with pytest.raises(ValueError, match="integrator must be a dcjax.Integrator"):
        dcjax.make_problem(sd1, "rk4")  # pyright: ignore[reportArgumentType]
    assert dcjax.make_problem(sd1, initial={"i_a": 0.5, "omega": 2.0}).y0.tolist() == [0.5, 2.0]


def test_identify_fleet_is_fit_each(sd1):
    from dcjax.compat import identify_fleet

    recs = [sd1.select(slice(0, 201)).replace(name=f"m{k}", i_a=sd1.i_a[:201] * (1 + 0.01 * k)) for k in range(3)]
    with pytest.warns(DeprecationWarning):
        fleet = identify_fleet(recs, budget=2100, runs=1, seed=0)
    each = dcjax.fit_each(recs, params="table4", search=dcjax.Search(runs=1, budget=2100, seed=0))
    for r, e in zip(fleet.results, each):
        np.testing.assert_array_equal(r.run_params, e.run_params)  # pyright: ignore[reportAttributeAccessIssue]
    assert fleet.params.shape == (3, 7)
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="equal length"):
        identify_fleet([recs[0], sd1.select(slice(0, 150))])
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="non-empty"):
        identify_fleet([])
