"""The model interface: a model from outside the package end to end, the Coulomb-friction
model on a reversing drive, fixed parameters, per-name bounds and start values."""

import json
import os
import subprocess
import sys
from typing import ClassVar

import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import DC, DCCoulomb, Model, Recording, datasets, get_model, make_problem, objective
from dcjax.cli import main

SD1 = datasets.true_params("SD1")


# -- a series-wound DC motor, defined as a user would --------------------------------------------
class SeriesWound(Model):
    """Field in series with the armature (flux ~ i): EMF Laf i w, torque Laf i^2.

    L di/dt = u - R i - Laf i w,      J dw/dt = Laf i^2 - Tl - B w
    """

    names: ClassVar = ("R", "L", "Laf", "J", "Tl", "B")
    units: ClassVar = {"R": "Ohm", "L": "H", "Laf": "H", "J": "kg m^2", "Tl": "Nm", "B": "Nm s"}
    states: ClassVar = ("i_a", "omega")
    inputs: ClassVar = ("u_a",)
    quantities: ClassVar = {"u_a": "voltage", "i_a": "current", "omega": "angular speed"}
    bounds: ClassVar = {
        "default": {"R": (0.0, 10.0), "L": (0.0, 1.0), "Laf": (0.0, 0.2), "J": (0.0, 0.1), "Tl": (0.0, 2.0), "B": (0.0, 0.05)}
    }

    def coefficients(self, p):
        inv_l, inv_j = 1.0 / p["L"], 1.0 / p["J"]
        return (inv_l, p["R"] * inv_l, p["Laf"] * inv_l, p["Laf"] * inv_j, p["Tl"] * inv_j, p["B"] * inv_j)

    def vector_field(self, c, u, y):
        gu, a, b, k, d, e = c
        i, w = y
        return gu * u[0] - a * i - b * i * w, k * i * i - d - e * w


SERIES_TRUE = {"R": 1.2, "L": 0.05, "Laf": 0.03, "J": 0.01, "Tl": 0.2, "B": 2e-3}


def rk4_numpy(f, y0, t, u, nd=1):
    """Plain NumPy RK4 over the sample grid with linear input interpolation (eq. 28-29)."""
    y = np.array(y0, float)
    out = [y.copy()]
    for k in range(1, len(t)):
        h = (t[k] - t[k - 1]) / nd
        for s in range(nd):
            ua = u[k - 1] + (u[k] - u[k - 1]) * s / nd
            ub = u[k - 1] + (u[k] - u[k - 1]) * (s + 1) / nd
            um = 0.5 * (ua + ub)
            k1 = f(ua, y)
            k2 = f(um, y + 0.5 * h * k1)
            k3 = f(um, y + 0.5 * h * k2)
            k4 = f(ub, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(y.copy())
    return np.array(out)


def series_recording(nd=1):
    p = SERIES_TRUE
    t = np.arange(301) * 1e-3
    u = np.where(t < 0.15, 48.0, 24.0)

    def f(u, y):
        i, w = y
        return np.array([(u - p["R"] * i - p["Laf"] * i * w) / p["L"], (p["Laf"] * i * i - p["Tl"] - p["B"] * w) / p["J"]])

    y = rk4_numpy(f, [0.0, 0.0], t, u, nd)
    return Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name="series")


def _params(model=None, preset=None, fixed=None, bounds=None, x0=None):
    """A model's `Parameters` (its default preset) with ranges, start values and fixed values set."""
    params = dcjax.get_model(model).parameters(preset)
    for n, (lo, hi) in (bounds or {}).items():
        params[n].set(min=lo, max=hi)
    for n, v in (x0 or {}).items():
        params[n].set(value=v)
    for n, v in (fixed or {}).items():
        params[n].set(value=v, vary=False)
    return params


def test_series_model_simulates_like_an_independent_numpy_rk4():
    rec = series_recording(nd=3)
    prob = make_problem(rec, dcjax.RK4(substeps=3), model=SeriesWound())
    sim = np.asarray(dcjax.simulate(SERIES_TRUE, prob))
    np.testing.assert_allclose(sim[:, 0], rec.i_a, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(sim[:, 1], rec.omega, rtol=1e-12, atol=1e-9)
    assert float(objective(SERIES_TRUE, prob)) < 1e-26


@pytest.mark.slow
def test_series_model_end_to_end_de_polish_uncertainty():
    rec = series_recording()
    r = dcjax.fit(rec, SeriesWound(), _params(SeriesWound()), dcjax.Search(runs=2, budget=42_000, seed=0, polish=True))
    assert r.names == SeriesWound.names and r.of < 1e-20, r.run_of
    for n, v in SERIES_TRUE.items():
        assert abs(r.params[n] - v) <= 1e-6 * v, (n, r.params[n], v)
    r = r.uncertainty()
    u = r.uncertainties
    assert set(u.se) == set(SeriesWound.names) and all(u.verdict[n] == "well determined" for n in SeriesWound.names), u.table()
    assert "[[Variables]]" in r.report() and "Laf" in r.report()


# -- Coulomb friction on a reversing drive ------------------------------------------------------------
def coulomb_reversal(w_eps=0.5):
    p = SD1
    t = np.arange(601) * 1e-4
    u = np.where(t < 0.02, 220.0, -220.0)

    def f(u, y):
        i, w = y
        sgn = w / np.sqrt(w * w + w_eps**2)
        torque = p["Tla"] * sgn + p["Tlb"] * w + p["Tlc"] * w * abs(w)
        return np.array([(u - p["Ra"] * i - p["cm"] * w) / p["La"], (p["cm"] * i - torque) / p["J"]])

    y = rk4_numpy(f, [0.0, 0.0], t, u)
    return Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name="reversal")


@pytest.mark.slow
def test_coulomb_model_recovers_friction_on_a_reversing_drive_and_dc_does_not():
    rec = coulomb_reversal()
    assert rec.omega.min() < -50 < 50 < rec.omega.max()  # it really reverses
    prob = make_problem(rec, model="dc-coulomb")
    x = jnp.asarray([SD1[n] for n in DC.names])
    assert float(objective(x, prob)) < 1e-28  # the same model as the NumPy reference
    kw = dict(search=dcjax.Search(runs=2, budget=70_000, seed=3))
    coul = dcjax.fit(rec, "dc-coulomb", _params("dc-coulomb", bounds={"Tla": (0.0, 0.1), "Tlc": (0.0, 1e-6)}), **kw)
    plain = dcjax.fit(rec, "dc", _params("dc", bounds={"Tla": (0.0, 0.1), "Tlc": (0.0, 1e-6)}), **kw)
    assert abs(coul.params["Tla"] - SD1["Tla"]) <= 1e-4 * SD1["Tla"], coul.params
    assert plain.of > 1e6 * coul.of and plain.of > 1e-12, (plain.of, coul.of)


def test_coulomb_sign_is_smooth_and_odd():
    m = DCCoulomb()
    c = m.coefficients({n: jnp.asarray(v) for n, v in SD1.items()})
    w = jnp.linspace(-3, 3, 61)
    _, dw_pos = m.vector_field(c, (0.0,), (0.0, w))
    _, dw_neg = m.vector_field(c, (0.0,), (0.0, -w))
    np.testing.assert_allclose(dw_pos, -dw_neg, rtol=1e-14)
    assert np.all(np.abs(np.diff(np.asarray(dw_pos))) < 0.2 * float(c.d))  # no jump at w = 0


# -- parameters by name ---------------------------------------------------------------------------------
def test_fixed_parameters_shrink_the_search_and_are_reported(sd1):
    r = dcjax.fit(sd1, params=_params(fixed={"Ra": 42.5, "Tlc": SD1["Tlc"]}), search=dcjax.Search(runs=2, budget=21_000, seed=0))
    assert r.params["Ra"] == 42.5 and r.params["Tlc"] == SD1["Tlc"] and np.all(r.run_params[:, 0] == 42.5)
    assert r.fixed == {"Ra": 42.5, "Tlc": SD1["Tlc"]}
    d = r.to_dict()
    assert d["fixed"] == r.fixed and d["free"] == ["La", "cm", "J", "Tla", "Tlb"] and set(d["params"]) == set(DC.names)
    u = r.uncertainty().uncertainties
    assert r.uncertainties is None  # a new result; this one is unchanged
    assert u.verdict["Ra"] == "fixed (known)" and u.se["Ra"] == 0.0 and u.verdict["La"] != "fixed (known)"
    with pytest.raises(ValueError, match="fixed"):
        r.uncertainty(profile="Ra")


def test_search_dimension_is_the_free_count(sd1):
    seen = {}

    class Spy(dcjax.strategies.DERand1Exp):
        def init(self, key, fn, budget, dim, x0=None):
            seen["dim"] = dim
            return super().init(key, fn, budget, dim, x0)

    dcjax.fit(sd1, params=_params(fixed={"Ra": 42.5, "Tlc": 0.0}), search=dcjax.Search(Spy(), runs=1, budget=140))
    assert seen["dim"] == 5


def test_bad_names_list_the_models_parameters(sd1):
    extra = dcjax.Parameters([*_params().values(), dcjax.Parameter("Rb", value=1.0, vary=False)])
    with pytest.raises(ValueError, match="unknown parameter.* Rb for model dc"):
        dcjax.fit(sd1, params=extra, search=dcjax.Search(runs=1, budget=70))
    with pytest.raises(ValueError, match="unknown fixed parameter 'Rb' for model dc; its parameters are Ra, La"):
        DC().check_names({"Rb": 1.0}, "fixed parameter")
    with pytest.raises(KeyError, match="Jx"):
        _params(bounds={"Jx": (0, 1)})
    with pytest.raises(ValueError, match="outside its bounds"):
        dcjax.fit(sd1, params=_params(x0={"Ra": 1e3}), search=dcjax.Search(runs=1, budget=70))
    with pytest.raises(ValueError, match="unknown model 'shunt'"):
        get_model("shunt")
    with pytest.raises(ValueError, match="cannot import model"):
        get_model("nosuchpkg.mod:Thing")


def test_start_values_seed_the_population(sd1):
    truth = {n: SD1[n] for n in DC.names}
    r = dcjax.fit(sd1, params=_params(x0=truth), search=dcjax.Search(runs=1, budget=70))  # one population: the seeded member is evaluated
    assert r.of < 1e-25


def test_per_name_bounds_override_the_preset(sd1):
    r = dcjax.fit(sd1, params=_params(bounds={"Ra": (40.0, 45.0)}), search=dcjax.Search(runs=1, budget=140))
    assert r.settings["bounds"]["lower"][0] == 40.0 and r.settings["bounds"]["upper"][1] == 1.0
    assert 40.0 <= r.params["Ra"] <= 45.0


@pytest.mark.slow
def test_cli_fix_bound_model_and_import_path(tmp_path, capsys):
    out = tmp_path / "fix"
    sd1_csv = str(datasets.DATA_DIR / "SD1.csv")
    assert main(["fit", sd1_csv, "--fix", "Ra=42.5,Tlc=8.55e-8", "--runs", "2", "--out", str(out)]) == 0
    d = json.loads((out / "result.json").read_text())
    assert d["params"]["Ra"] == 42.5 and set(d["fixed"]) == {"Ra", "Tlc"} and len(d["runs"]) == 2
    for n in ("La", "cm", "J", "Tla", "Tlb"):
        assert abs(d["params"][n] - SD1[n]) <= 1e-6 * SD1[n]
    assert "(fixed)" in capsys.readouterr().out
    assert main(["fit", sd1_csv, "--model", "dc-coulomb", "--runs", "1", "--budget", "140", "--out", str(tmp_path / "c")]) == 0
    assert json.loads((tmp_path / "c" / "result.json").read_text())["model"] == "dc-coulomb"
    series = tmp_path / "series.csv"
    dcjax.save_csv(series_recording(), series)
    assert (
        main(
            [
                "fit",
                str(series),
                "--model",
                "test_models:SeriesWound",
                "--runs",
                "1",
                "--budget",
                "140",
                "--bound",
                "R=0.5:2",
                "--out",
                str(tmp_path / "s"),
            ]
        )
        == 0
    )
    d = json.loads((tmp_path / "s" / "result.json").read_text())
    assert d["model"] == "test_models:SeriesWound" and set(d["params"]) == set(SERIES_TRUE)
    assert d["settings"]["bounds"]["lower"][0] == 0.5


@pytest.mark.parametrize(
    "args,match",
    [
        (["--fix", "Rx=1"], "unknown fixed parameter 'Rx'"),
        (["--fix", "Ra"], "NAME=VALUE"),
        (["--fix", "Ra=abc"], "must be a finite number"),
        (["--bound", "Ra=1"], "LOWER:UPPER"),
        (["--bound", "Ra=5:1"], "lower bound above upper"),
        (["--model", "nope"], "unknown model"),
        (["--x0", "Ra=1e9"], "outside its bounds"),
    ],
)
def test_cli_parameter_errors_are_one_line(args, match, capsys, tmp_path):
    assert main(["fit", "SD1", "--runs", "1", "--budget", "70", "--out", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.slow
def test_import_changes_no_xla_flags():
    """Importing dcjax leaves XLA_FLAGS alone, and imports neither diffrax nor optimistix (0.3 s of
    every command's start: they load where a fit first uses them)."""
    code = (
        "import os, sys; a = os.environ.get('XLA_FLAGS'); import dcjax; assert os.environ.get('XLA_FLAGS') == a; "
        "print(len(__import__('jax').devices()), sorted(m for m in ('diffrax', 'optimistix', 'lineax') if m in sys.modules))"
    )
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert p.returncode == 0 and p.stdout.strip() == "1 []", p.stdout + p.stderr
    code = "import dcjax; print(dcjax.use_host_devices(2), len(__import__('jax').devices()))"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert p.stdout.split() == ["2", "2"], p.stderr


LOOP_PROBE = """
import os, warnings
import dcjax, jax, jax.numpy as jnp
from dcjax import datasets
on = dcjax.use_compiled_loops({arg})
prob = dcjax.make_problem(datasets.load("SD1"))
x = jnp.tile(jnp.asarray(datasets.true_params("SD1")["Ra"]), (70, 7))
text = jax.jit(lambda x: dcjax.objective(x, prob)).lower(x).compile().as_text()
with warnings.catch_warnings(record=True) as late:
    warnings.simplefilter("always")
    again = dcjax.use_compiled_loops()
print(on, "xla_cpu_small_call" in text, again, len(late), os.environ.get("XLA_FLAGS", "").count("small_while"), dcjax.devices.compiled_loop_bytes())
"""


@pytest.mark.parametrize(
    "flags, arg, expect",
    [
        (None, "", ["True", "True", "True", "0", "1", "16777216"]),  # on: the time loop is one call
        pytest.param(None, "512", ["True", "False", "True", "0", "1", "512"], marks=pytest.mark.slow),  # a 17 KB loop is above 512 bytes
        pytest.param(
            "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1024",
            "",
            ["True", "False", "True", "0", "1", "1024"],
            marks=pytest.mark.slow,
        ),  # a process each (3-4 s): the default and a user's own option in the fast run
        ("--xla_backend_extra_options=xla_llvm_dot_tiling_factor=4", "", ["False", "False", "False", "0", "0", "1024"]),  # user's: kept
    ],
)
def test_use_compiled_loops(flags, arg, expect):
    """Off by default (test_import_changes_no_xla_flags); `use_compiled_loops()` compiles the
    objective's time loop as one function, leaves a user's `xla_backend_extra_options` alone and
    does not add its option twice; `compiled_loop_bytes` reads the threshold in force (XLA's 1 KiB
    where none is set)."""
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    if flags:
        env["XLA_FLAGS"] = flags
    p = subprocess.run([sys.executable, "-c", LOOP_PROBE.format(arg=arg)], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == expect


def test_use_compiled_loops_after_start_warns():
    code = "import dcjax, jax, warnings; jax.numpy.ones(1).block_until_ready(); warnings.simplefilter('error'); dcjax.use_compiled_loops()"
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert p.returncode != 0 and "before any JAX computation" in p.stderr
    with pytest.raises(ValueError, match="max_bytes"):
        dcjax.use_compiled_loops(0)


def test_derived_quantities_of_the_dc_motor_against_the_reference_simulator():
    """`DC.derived`: the static speed gain is the speed the independent NumPy RK4 settles at per
    volt (Tla = Tlc = 0), the electrical and mechanical time constants the stated ratios; the
    report prints them."""
    import reference as ref

    p = dict(Ra=42.5, La=0.08, cm=0.4781, J=2e-5, Tla=0.0, Tlb=3.27e-5, Tlc=0.0)
    d = dcjax.DC().derived(p)
    rest = ref.settle(ref.dc_field, p, np.array([100.0]), np.zeros(2), 0.5)
    assert d["static speed gain omega/u_a"][0] == pytest.approx(rest[1] / 100.0, rel=1e-9)
    assert d["electrical time constant La/Ra"] == (pytest.approx(0.08 / 42.5), "s")
    assert d["mechanical time constant Ra J/(cm^2 + Ra Tlb)"][0] == pytest.approx(42.5 * 2e-5 / (0.4781**2 + 42.5 * 3.27e-5))
    assert dcjax.Model.derived(dcjax.DC(), p) == {}  # the protocol's default: nothing derived
