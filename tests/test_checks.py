"""A lab's folder: data checks name every broken recording and no clean one, the outlier rule
finds bad fits and not numerical zeros, `--each` reports per file and splits its time, validation
reads files as the fit did, and verdicts and figures say what they mean."""

import csv
import dataclasses
import json
import re
from pathlib import Path

import equinox as eqx
import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli, datasets
from dcjax.analysis.checks import check_recording, count_findings, fit_findings, fleet_findings, from_error
from dcjax.analysis.report import fit_report
from dcjax.fitting.summary import outlier_flags, robust_outliers
from experiments.synthetic_fleet import EXPECTED, write_fleet


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fleet")
    return folder, write_fleet(folder, clean=20, samples=665)


def _findings(folder: Path, kinds: dict[str, str]) -> dict[str, list]:
    """Every file's findings before a fit: a loading error's named finding, else the checks of
    the recording and of the fleet."""
    model = dcjax.DC()
    out, loaded = {}, {}
    for name in kinds:
        try:
            loaded[name] = dcjax.load_recording(folder / f"{name}.csv")
        except ValueError as e:
            out[name] = [from_error(e)]
    for (name, rec), extra in zip(loaded.items(), fleet_findings(list(loaded.values()), model)):
        out[name] = check_recording(rec, model) + extra
    return out


def test_every_broken_recording_gets_its_named_finding_and_no_clean_one_any(fleet):
    folder, kinds = fleet
    found = _findings(folder, kinds)
    for name, kind in kinds.items():
        if kind == "clean":
            assert found[name] == [], (name, found[name])
        elif kind != "slow-rate":  # judged after the fit (test_each_*)
            severity, label = EXPECTED[kind]
            match = [f for f in found[name] if f is not None and (f.label == label or f.check == label)]
            assert match and match[0].severity == severity, (name, found[name])


def test_the_outlier_rule_skips_values_at_a_bound_and_flags_bad_fits():
    @dataclasses.dataclass
    class Fit:  # what the rule reads of a result
        at: tuple
        fixed: dict = dataclasses.field(default_factory=dict)

        def at_bound(self, rtol):
            return list(self.at)

    rng = np.random.default_rng(0)
    rows, fits = [], []
    for _ in range(20):
        zero = 10.0 ** rng.uniform(-25, -18)  # a load coefficient at its zero bound: a numerical zero
        rows.append({"of": 1e-4 * rng.uniform(0.9, 1.1), "Ra": 4 * rng.uniform(0.9, 1.1), "Tlb": zero, "fit_i_a": 97.0})
        fits.append(Fit(at=("Tlb",)))
    rows[3]["of"] = 0.1  # a bad fit: its OF far above the fleet's
    rows[5]["fit_i_a"] = -12.0  # a channel the model does not follow
    rows[7]["Ra"] = 400.0  # an outlying value that carries information
    flags = outlier_flags(rows, fits, ("Ra", "Tlb"))  # pyright: ignore[reportArgumentType]
    assert flags[3] == ["of"] and flags[5] == ["fit_i_a"] and flags[7] == ["Ra"]
    assert all(not flags[k] for k in range(20) if k not in (3, 5, 7))
    assert not robust_outliers(np.array([1.0, 1.0, 1.1, 0.9, 1e-6]), above_only=True)[-1]  # a low OF is no bad fit


def test_saturation_needs_a_steep_entry_and_a_quantised_plateau_is_not_one():
    t = np.arange(400) * 1e-3
    rise = 1 - np.exp(-t / 0.02)
    plateau = np.round(rise * 100) / 100  # quantised steady state: many samples equal to the maximum
    rec = dcjax.Recording(t=t, u_a=np.ones_like(t), i_a=np.exp(-t / 0.01) + 0.1, omega=plateau)
    assert not [f for f in check_recording(rec, dcjax.DC()) if f.check == "saturated"]
    clipped = rec.replace(i_a=np.clip(3 * np.sin(np.pi * t / 0.4), -1.5, 1.5))  # a half sine clipped at half its peak
    assert [f.label for f in check_recording(clipped, dcjax.DC()) if f.check == "saturated"] == ["saturated:i_a"]


def test_an_input_without_excitation_and_a_one_sample_pulse_are_named():
    t = np.arange(400) * 1e-3
    decay = 100 * np.exp(-t / 0.1)
    by_hand = dcjax.Recording(t=t, u_a=np.zeros_like(t), i_a=-0.01 * decay, omega=decay)
    found = [f for f in check_recording(by_hand, dcjax.DC()) if f.check == "no-input"]
    assert [f.severity for f in found] == ["warning"] and "zero throughout while i_a, omega moves" in found[0].message
    noise = np.random.default_rng(0).normal(size=(2, t.size))
    still = dcjax.Recording(t=t, u_a=np.full_like(t, 12.0), i_a=0.3 + 1e-3 * noise[0], omega=25 + 1e-2 * noise[1])
    assert [f.message.split(":")[0] for f in check_recording(still, dcjax.DC())] == ["input u_a is constant and nothing moves"]
    step = still.replace(i_a=np.exp(-t / 0.01), omega=30 * (1 - np.exp(-t / 0.05)))  # a switch-on step from rest: excited
    assert not [f for f in check_recording(step, dcjax.DC()) if f.check in ("no-input", "pulse")]
    pulse = np.zeros_like(t)
    pulse[100] = 2.0
    kicked = step.replace(u_a=pulse)
    assert [f.label for f in check_recording(kicked, dcjax.DC()) if f.check == "pulse"] == ["pulse:u_a"]
    assert [f.check for f in check_recording(kicked.replace(u_a=np.where(np.arange(400) % 50 < 2, 2.0, 0.0)), dcjax.DC())
            if f.check == "pulse"] == []  # two samples are resolved  # fmt: skip


class Product(dcjax.Model):
    """dy/dt = u - a b y: a and b only as their product (a null direction of the Jacobian)."""

    names = ("a", "b")
    states = ("y",)
    inputs = ("u",)

    def vector_field(self, c, u, y):
        return (u[0] - c["a"] * c["b"] * y[0],)


def test_a_parameter_in_a_null_direction_prints_a_dash_not_a_standard_error():
    from dcjax.analysis.uncertainty import uncertainty

    t = np.arange(200) * 1e-2
    m = Product()
    rec0 = dcjax.Recording(t=t, u=np.ones_like(t), y=np.ones_like(t))
    y = np.asarray(dcjax.simulate({"a": 2.0, "b": 1.5}, dcjax.make_problem(rec0, model=m, initial={"y": 0.0})))[:, 0]
    rec = rec0.replace(y=y + 1e-3 * np.sin(37 * t))
    prob = dcjax.make_problem(rec, model=m)
    u = uncertainty(np.array([2.0, 1.5]), prob, dcjax.Bounds([0.1, 0.1], [10.0, 10.0], ("a", "b")))
    assert all(np.isnan(u.se[n]) for n in "ab") and all(u.verdict[n].startswith("not identifiable") for n in "ab")
    rows = u.table().splitlines()[1:3]
    assert all(re.search(r"\s-\s+-\s+-\s", r) for r in rows), rows
    assert u.null_names == ("a", "b") and u.combinations["b*a"][0] == pytest.approx(3.0)  # only the product is determined


def test_fit_png_of_a_joint_fit_stays_small_and_axes_carry_units(sd1, tmp_path):
    r = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=1, budget=140))
    many = dataclasses.replace(r, recordings=[sd1] * 16)
    fig = many.plot(tmp_path / "fit.png")
    assert (tmp_path / "fit.png").stat().st_size <= 300_000
    labels = {ax.get_ylabel() for ax in fig.axes}
    assert {"i_a (A)", "omega (rad/s)", "residual i_a (A)"} <= labels and "u_a (V)" not in labels  # SD1's input is a constant
    assert all(ax.lines for ax in fig.axes) and len(fig.axes) == 4 * 4 + 1  # no empty panel: 4 rows of 2 channels x 2, convergence
    assert fig.axes[0].get_title() == "SD1: u_a = 220 V (constant); i_a"
    assert fig._suptitle is not None and "the first 4 of 16 recordings" in fig._suptitle.get_text()  # pyright: ignore


@pytest.mark.slow
def test_each_on_the_fleet_names_every_finding_flags_no_clean_one_and_splits_its_time(fleet, tmp_path, capsys):
    folder, kinds = fleet
    files = [str(folder / f"{n}.csv") for n in kinds]
    rc = cli.main(["fit", "--each", *files, "--bounds", "auto", "--runs", "2", "--out", str(tmp_path), "--no-progress"])
    assert rc == 1  # some files failed alone, the others were fitted
    rows = {r["name"]: r for r in csv.DictReader((tmp_path / "summary.csv").open())}
    for name, kind in kinds.items():
        row = rows[name]
        if kind == "clean":
            assert row["status"] == "ok" and row["checks"] == "" and row["outlier"] == "", row
            continue
        severity, label = EXPECTED[kind]
        assert label in row["checks"].split() or any(c.split(":")[0] == label for c in row["checks"].split()), row
        assert row["status"] == ("failed" if severity == "error" else "ok"), row
    assert any(float(rows[n]["Tlb"]) < 1e-12 for n, k in kinds.items() if k == "clean")  # Tlb fit at 0: no outlier for it
    out, err = capsys.readouterr()
    progress = [line for line in err.splitlines() if line.startswith("[")]
    assert len(progress) == len(kinds) and progress[-1].endswith("0 left")
    last = out.strip().splitlines()[-1]
    parts = dict((k, float(v)) for k, v in re.findall(r"([a-z+]+) ([0-9.]+) s", last))
    assert set(parts) == {"load+checks", "estimate", "compile", "search", "write+plots"}, last
    outside = parts["load+checks"] + parts["estimate"] + parts["write+plots"]
    assert outside <= 0.25 * sum(parts.values()), last
    assert (tmp_path / "summary.png").is_file() and not (tmp_path / "motor000" / "fit.png").exists()  # --plots summary


@pytest.mark.slow
def test_validate_reads_the_file_as_the_fit_did_and_warns_of_a_scale_slip(tmp_path, capsys):
    sd1 = datasets.load("SD1")
    rpm = sd1["omega"] * 60 / (2 * np.pi)
    table = np.column_stack([sd1.t * 1e3, sd1["u_a"], sd1["i_a"] * 1e3, rpm / 3.0])  # ms, V, mA, rpm behind a 3:1 gear
    path = tmp_path / "bench.csv"
    np.savetxt(path, table, delimiter=",", header="t,u_a,i_a,omega", comments="")
    opts = ["--units", "t=ms,i_a=mA,omega=rpm", "--scale", "omega=3"]
    assert cli.main(["fit", str(path), *opts, "--bounds", "table4", "--runs", "2", "--budget", "1400", "--out", str(tmp_path / "f")]) == 0
    capsys.readouterr()
    assert cli.main(["validate", str(tmp_path / "f" / "result.json"), str(path), "--out", str(tmp_path / "v")]) == 0
    out, err = capsys.readouterr()
    of_fit = dcjax.load_result(tmp_path / "f" / "result.json").of
    of_val = json.loads((tmp_path / "v" / "validation.json").read_text())[0]["of"]
    assert of_val == pytest.approx(of_fit, rel=1e-9) and "slip" not in err
    assert (
        cli.main(
            ["validate", str(tmp_path / "f" / "result.json"), str(path), "--units", "t=ms,i_a=mA,omega=rpm", "--out", str(tmp_path / "w")]
        )
        == 0
    )
    _, err = capsys.readouterr()  # --units given, --scale forgotten: omega's peak is 1/3 of the fit's (within 10x: no warning)
    assert "slip" not in err
    assert cli.main(["validate", str(tmp_path / "f" / "result.json"), str(path), "--units", "t=ms", "--out", str(tmp_path / "x")]) == 0
    _, err = capsys.readouterr()  # mA read as A: a 1000x slip
    assert "the peak of i_a is 1e+03x the fitted recording's" in err and "unit or scale slip" in err
    kicked = table.copy()
    kicked[:, 1] = 0.0
    kicked[50, 1] = 20 * table[:, 1].max()  # one sample of 20x the fitted voltage: a pulse, not a slip
    np.savetxt(tmp_path / "kick.csv", kicked, delimiter=",", header="t,u_a,i_a,omega", comments="")
    assert cli.main(["validate", str(tmp_path / "f" / "result.json"), str(tmp_path / "kick.csv"), "--out", str(tmp_path / "k")]) == 0
    _, err = capsys.readouterr()
    assert "the peak of u_a" in err and "is a pulse shorter than two samples" in err and "slip" not in err


@pytest.mark.slow
def test_plots_option_and_a_progress_line_per_file(tmp_path, capsys):
    sd = [datasets.DATA_DIR / f"SD{k}.csv" for k in (1, 2)]
    rc = cli.main(
        ["fit", "--each", *map(str, sd), "--runs", "1", "--budget", "140", "--plots", "none", "--out", str(tmp_path), "--no-progress"]
    )
    assert rc == 0 and not (tmp_path / "summary.png").exists() and not (tmp_path / "SD1" / "fit.png").exists()
    err = capsys.readouterr().err.splitlines()
    assert [line.split(":")[0] for line in err if line.startswith("[")] == ["[1/2] SD1", "[2/2] SD2"]
    rc = cli.main(["fit", "--each", str(sd[0]), "--runs", "1", "--budget", "140", "--plots", "each", "--out", str(tmp_path / "e")])
    assert rc == 0 and (tmp_path / "e" / "SD1" / "fit.png").is_file()
    capsys.readouterr()
    assert cli.main(["fit", str(sd[0]), "--plots", "sometimes"]) == 2  # the parser's error: one line
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("dcjax: error: argument --plots: invalid choice: 'sometimes'")
    assert cli.main(["fit", str(sd[0]), "--plots", "summary", "--out", str(tmp_path / "x")]) == 2  # goes with --each
    assert cli.main(["fit", *map(str, sd), "--plots", "none", "--runs", "1", "--budget", "140", "--out", str(tmp_path / "j")]) == 0
    assert (tmp_path / "j" / "result.json").is_file() and not (tmp_path / "j" / "fit.png").exists()  # a joint fit without its plot


def test_a_zero_at_a_required_parameter_is_a_failed_fit_hint():
    from dcjax.cli.fit_lines import bound_hints

    @dataclasses.dataclass
    class R:
        best_values: dict
        model: eqx.Module
        names: tuple = dcjax.DC.names
        bounds: object = dcjax.Bounds(np.zeros(7), np.ones(7), dcjax.DC.names)

        def at_bound(self):
            return ["cm", "Tlb"]

    hints = bound_hints(R({**dict.fromkeys(dcjax.DC.names, 0.5), "cm": 0.0, "Tlb": 0.0}, dcjax.DC()))
    assert "physics needs it" in hints[0] and "cm" in hints[0]
    assert "does not need the term" in hints[1] and "Tlb" in hints[1]


def test_fit_findings_flag_a_rate_slower_than_la_over_ra_and_a_channel_not_followed(sd1):
    from dcjax.analysis.checks import fit_findings

    r = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=1, budget=140))
    truth = datasets.true_params("SD1")  # La/Ra = 1.9 ms, dt = 0.1 ms: resolved
    good = dataclasses.replace(r, best_values=truth)
    assert [f.check for f in fit_findings(good)] == []
    fast_tau = dataclasses.replace(r, best_values={**truth, "La": 1e-6})  # La/Ra = 24 ns < dt (and dt / ND)
    slow = [f for f in fit_findings(fast_tau) if f.check == "slow-rate"]
    assert slow and "the integration step 0.0001 s (the sample interval over ND=1) is longer than the fitted La/Ra" in slow[0].message
    sub = dataclasses.replace(r, best_values={**truth, "La": 2.1e-3}, integrator=dcjax.RK4(substeps=64))  # dt / 64 < La/Ra = 49 us < dt
    slow = [f for f in fit_findings(sub) if f.check == "slow-rate"]
    assert slow and "only the samples right after each change of the input show it" in slow[0].message
    bad = fit_findings(good, fits={"i_a": 95.0, "omega": -3.0})
    assert [f.label for f in bad] == ["no-follow:omega"] and bad[0].severity == "warning"


def test_a_fit_with_no_more_values_than_free_parameters_says_so(sd1, tmp_path, capsys):
    """3 samples x 2 channels for 7 parameters: `few-data`, in the result and on the command line;
    8 values outnumber them: none. The paper's data, cut."""
    search = dcjax.Search(runs=1, budget=140)
    few = lambda r: [f for f in r.checks if f.check == "few-data"]
    three = dcjax.fit(sd1.select(slice(0, 3)), params="table4", search=search)
    assert [f.message.split(":")[0] for f in few(three)] == ["6 compared values (samples x channels) for 7 free parameters"]
    assert few(three)[0].severity == "warning"
    assert [len(count_findings(n, 7)) for n in (6, 7, 8)] == [1, 1, 0]  # as many values as parameters: few; 8 (4 samples): none
    short = tmp_path / "short.csv"
    short.write_text("".join((datasets.DATA_DIR / "SD1.csv").read_text().splitlines(True)[:4]))
    flags = ["--bounds", "table4", "--runs", "1", "--budget", "140", "--plots", "none", "--out", str(tmp_path / "out")]
    assert cli.main(["fit", str(short), *flags]) == 0
    assert "check warning: few-data: 6 compared values (samples x channels) for 7 free parameters" in capsys.readouterr().out
    assert cli.main(["report", str(tmp_path / "out" / "result.json")]) == 0  # the file carries it, its report names it
    report = capsys.readouterr().out
    assert "[[Checks]]\n" in report and "\n    warning: few-data: 6 compared values" in report
    section = three.report().split("[[Checks]]\n")[1].split("\n[[")[0].splitlines()  # with the after-fit ones
    assert section == [f"    {f}" for f in [*three.checks, *fit_findings(three)]] and "[[Checks]]" not in fit_report(three, findings=[])


@pytest.mark.slow  # two fits with a polish
def test_an_integration_step_longer_than_la_over_ra_biases_the_fit_and_says_so():
    """A small motor sampled at 1 kHz (La/Ra = 0.57 ms; the NumPy reference at 64 sub-steps,
    noise-free): fitted from 3 % off the truth at ND=1 (a 1 ms step) La ends > 5 % off and the
    check says the fit is biased and how to refit (it said "La cannot be resolved at this rate");
    at ND=4 every parameter is within 1 % and it does not."""
    from dcjax.analysis.checks import fit_findings

    truth = dict(Ra=2.1, La=1.2e-3, cm=0.021, J=3.5e-6, Tla=2e-4, Tlb=4e-7, Tlc=0.0)
    t = np.arange(600) * 1e-3
    u = np.repeat(np.random.default_rng(1).choice([0.0, 6.0, 12.0], 16), 40)[: t.size]
    y = ref.simulate(lambda p, v, x: ref.dc_field(p, v, x), truth, t, u[:, None], [0.0, 0.0], substeps=64)
    rec = dcjax.Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name="hobby")
    params = dcjax.Parameters(
        [dcjax.Parameter(n, value=v * (1.03 if k % 2 else 0.97), min=0.7 * v, max=1.4 * v) for k, (n, v) in enumerate(truth.items()) if v]
        + [dcjax.Parameter("Tlc", value=0.0, vary=False)]
    )
    off = {}
    for nd in (1, 4):
        r = dcjax.fit(rec, params=params, search=dcjax.Search(runs=1, budget=70, polish=True), integrator=dcjax.RK4(substeps=nd))
        off[nd] = max(abs(r.best_values[n] / v - 1) for n, v in truth.items() if v)
        findings = fit_findings(r)
        slow = [f.message for f in findings if "integration step" in f.message]
        assert bool(slow) == (nd == 1) and all("which biases the fit; refit with integrator=dcjax.AutoSubsteps()" in m for m in slow), slow
        assert "held" not in {f.check for f in findings}  # interpolated as the data were (at ND=1 the integrator is named first)
        if nd == 1:  # where --nd auto chose this ND (without converging), the check names a fixed ND that resolves La/Ra instead
            chosen = [f.message for f in fit_findings(dataclasses.replace(r, nd_auto={"chosen": 1, "converged": False}))]
            assert any("--nd auto stopped at ND=1" in m and m.endswith("refit with integrator=dcjax.RK4(substeps=2)") for m in chosen), (
                chosen
            )
    assert off[1] > 0.05 and off[4] < 0.01, off


@pytest.mark.slow  # two fits with a polish
def test_an_input_held_between_samples_but_interpolated_is_named():
    """The same motor driven by a DAQ that holds each value between samples (the NumPy reference's
    zero-order hold), sensor noise 0.3 % of the peaks: fitted with the default linear interpolation
    (eq. 29, each step moved into the interval before it) La ends > 3 % off and the `held` check
    says to refit with a zero-order hold; with `hold={"u_a": "zoh"}` every parameter but the weak
    load torque is within 1 % and it says nothing."""
    from dcjax.analysis.checks import fit_findings

    truth = dict(Ra=2.1, La=1.2e-3, cm=0.021, J=3.5e-6, Tla=2e-4, Tlb=4e-7, Tlc=0.0)
    t = np.arange(600) * 2e-4
    u = np.repeat(np.random.default_rng(1).choice([0.0, 6.0, 12.0], 16), 40)[: t.size]
    y = ref.simulate(lambda p, v, x: ref.dc_field(p, v, x), truth, t, u[:, None], [0.0, 0.0], substeps=64, held=(0,))
    rng = np.random.default_rng(2)
    y = y + 0.003 * np.max(np.abs(y), axis=0) * rng.standard_normal(y.shape)
    rec = dcjax.Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name="daq")
    params = dcjax.Parameters(
        [dcjax.Parameter(n, value=v * (1.03 if k % 2 else 0.97), min=0.7 * v, max=1.4 * v) for k, (n, v) in enumerate(truth.items()) if v]
        + [dcjax.Parameter("Tlc", value=0.0, vary=False)]
    )
    obs = {"initial": {"i_a": "measured", "omega": "measured"}}
    off, held = {}, {}
    for hold in ({}, {"u_a": "zoh"}):
        r = dcjax.fit(rec, params=params, search=dcjax.Search(runs=1, budget=70, polish=True), integrator=dcjax.RK4(substeps=4),
                      observation=dcjax.Observation(hold=hold, **obs))  # fmt: skip
        off[bool(hold)] = max(abs(r.best_values[n] / truth[n] - 1) for n in ("Ra", "La", "cm", "J"))
        held[bool(hold)] = [f.message for f in fit_findings(r) if f.check == "held"]
    assert off[False] > 0.03 and off[True] < 0.01, off
    assert len(held[False]) == 1 and "refit with hold={'u_a': 'zoh'}" in held[False][0] and not held[True], held


def test_fit_each_checks_each_recording_unless_told_not_to(sd1):
    rev = sd1.replace(i_a=-sd1["i_a"], omega=-sd1["omega"], name="rev")  # wired in reverse
    (a,) = dcjax.fit_each([rev], params="table4", search=dcjax.Search(runs=1, budget=140))
    (b,) = dcjax.fit_each([rev], params="table4", checks=False, search=dcjax.Search(runs=1, budget=140))
    assert "reversed:omega" in {f.label for f in a.checks} and not b.checks  # (SD1's current is a spike: a weak cosine)


def test_median_is_numpys_to_the_bit():
    """The checks' one-partition median against `np.median`: odd and even lengths, ties, zeros of
    either sign, NaN."""
    from dcjax.analysis.checks import median

    rng = np.random.default_rng(1)
    for n in [*range(1, 24), 699, 700]:
        for kind in range(4):
            a = rng.normal(size=n) * 10 ** rng.uniform(-5, 5)
            a = np.round(a) if kind == 1 else -np.zeros(n) if kind == 2 else a
            if kind == 3 and n > 2:
                a[rng.integers(n)] = np.nan
            want = np.median(a)
            assert np.float64(median(a)).tobytes() == np.float64(want).tobytes() or (np.isnan(want) and np.isnan(median(a))), (n, kind)


def test_the_outliers_line_tells_recordings_of_one_name_apart():
    """Files whose sidecars give one name (SD1 cut to 20 lengths): the line named the outlier
    "SD1", where summary.csv's folder is SD1_8."""
    from dcjax.cli.each import flagged_names

    rows = [
        {"name": "SD1", "folder": "SD1", "file": "f310.csv", "outlier": ""},
        {"name": "SD1", "folder": "SD1_2", "file": "f320.csv", "outlier": "Tlb"},
        {"name": "SD1", "folder": "", "file": "f330.csv", "outlier": "of"},  # failed: no folder
    ]
    assert flagged_names(rows) == ["SD1_2", "f330.csv"]
    rows[0]["name"], rows[1]["name"] = "a", "b"
    rows[2]["name"] = "c"
    assert flagged_names(rows) == ["b", "c"]
