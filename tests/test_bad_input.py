"""Nothing runs, nothing is lost, nothing is silent (issue 51): a result file that names code never
gets it imported, a recording's name never takes a write outside --out, every silent case of the
issue is a one-line error or a named warning, outputs are written whole by one writer, and a
logger's export reads as it comes. The cases are a careful user's and a hostile file's; each
asserts the one line (no traceback) and what is (not) on disk afterwards."""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dcjax
from dcjax import cli, datasets
from dcjax.cli.output import OutputFolder
from dcjax.io.files import safe_name, strict_json

ROOT = Path(__file__).resolve().parents[1]
TINY = ["--bounds", "table4", "--runs", "1", "--budget", "140", "--plots", "none"]
EVIL = "import pathlib\npathlib.Path({marker!r}).write_text('ran')\nimport dcjax\n\n\nclass Evil(dcjax.DC):\n    pass\n"


def one_line(err: str) -> str:
    """stderr's one error line (no traceback), a `dcjax.DcjaxError`'s (another exception's line
    names its type: `dcjax: error: KeyError: ...`)."""
    lines = [x for x in err.strip().splitlines() if x.startswith("dcjax: error")]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert not re.match(r"dcjax: error: [A-Za-z]+(Error|Exception): ", lines[0]), lines[0]
    return lines[0]


def short_sd1(folder: Path, name: str = "SD1", n: int = 200) -> Path:
    """The first `n` samples of SD1 as `folder/name.csv` (dcjax's layout, no sidecar)."""
    folder.mkdir(parents=True, exist_ok=True)
    dcjax.save_csv(datasets.load("SD1").select(slice(0, n)), folder / f"{name}.csv")
    (folder / f"{name}.json").unlink()
    return folder / f"{name}.csv"


@pytest.fixture(scope="module")
def saved(tmp_path_factory) -> Path:
    """A fit of a data file: its result.json (and the file) in a folder of their own."""
    folder = tmp_path_factory.mktemp("saved")
    data = short_sd1(folder / "data")
    assert cli.main(["fit", str(data), *TINY, "--out", str(folder / "fit")]) == 0
    return folder / "fit" / "result.json"


def edited(saved: Path, folder: Path, change) -> Path:
    """A copy of the saved result's folder (its data beside) with `change(d)` applied to result.json."""
    shutil.copytree(saved.parent.parent, folder, dirs_exist_ok=True)
    path = folder / "fit" / "result.json"
    d = json.loads(path.read_text())
    change(d)
    path.write_text(json.dumps(d))
    return path


# -- (a) a result file is data ---------------------------------------------------------------------
def test_a_result_naming_code_never_imports_it(saved, tmp_path, monkeypatch, capsys):
    marker = tmp_path / "MARKER"
    for name in ("evil.py", "evilmod.py"):
        (tmp_path / name).write_text(EVIL.format(marker=str(marker)))
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))  # a module in the current folder is importable, as under python -m
    data = str(saved.parent.parent / "data" / "SD1.csv")
    specs = [f"{tmp_path / 'evil.py'}:Evil", "evil.py:Evil", "evilmod:Evil", "os:system", "sys:exit"]
    for k, spec in enumerate(specs):
        res = str(edited(saved, tmp_path / f"r{k}", lambda d, s=spec: d.__setitem__("model", s)))
        commands = [["report", res], ["simulate", res, data, "--out", str(tmp_path / "s")], ["validate", res, data, "--out", str(tmp_path / "v")],
                    ["sample", res, "--draws", "5", "--warmup", "5", "--out", str(tmp_path / "p")],
                    ["design", res, "--duration", "0.01", "--dt", "1e-4", "--umin", "0", "--umax", "220", "--out", str(tmp_path / "d")]]  # fmt: skip
        for cmd in commands:
            assert cli.main(cmd) == 2, cmd
            assert "--model" in one_line(capsys.readouterr().err)
        with pytest.raises(
            ValueError, match=r"is not built in \(dc, dc-coulomb, pmsm, servo\), and dcjax does not import code a result file names"
        ):
            dcjax.load_result(res)
        assert not marker.exists(), spec
    res = str(edited(saved, tmp_path / "i", lambda d: d["settings"].__setitem__("integrator", "evilmod:Evil")))
    assert cli.main(["report", res]) == 2 and "settings.integrator 'evilmod:Evil' is not built in" in one_line(capsys.readouterr().err)
    assert not marker.exists() and "evilmod" not in sys.modules
    res = str(edited(saved, tmp_path / "named", lambda d: d.__setitem__("model", specs[0])))
    assert cli.main(["report", res, "--model", specs[0]]) == 0 and marker.exists()  # the user names it: imported


def test_a_sidecar_name_never_writes_outside_out(tmp_path, capsys):
    names = ["../../escaped", str(tmp_path / "abs" / "x"), "a/b", "..", "SD1", "sd1"]
    files = []
    for k, name in enumerate(names):
        f = short_sd1(tmp_path / "data", f"f{k}", n=120)
        f.with_suffix(".json").write_text(json.dumps({"name": name}))
        files.append(str(f))
    out = tmp_path / "run" / "out"
    assert (
        cli.main(["fit", "--each", *files, str(tmp_path / "data" / "f0.json"), *TINY, "--out", str(out)]) == 0
    )  # a sidecar is no recording
    written = {p.relative_to(tmp_path).parts[0] for p in tmp_path.rglob("*") if p.is_file()}
    assert written == {"data", "run"} and not (tmp_path / "abs").exists() and not (tmp_path / "escaped").exists()
    folders = sorted(p.name for p in out.iterdir() if p.is_dir())
    assert len(folders) == len(names) and all(f == safe_name(f) for f in folders)
    assert {"escaped", "a_b", "recording", "SD1", "sd1_2"} <= set(folders)  # distinct on a case-insensitive disk too


def test_safe_names():
    assert [safe_name(n) for n in ["../../x", "/abs/p", "a b", "..", "", ".hidden", "ok-1.2_x+y"]] == [
        "x", "abs_p", "a_b", "recording", "recording", "hidden", "ok-1.2_x+y"]  # fmt: skip
    assert safe_name("run", ["run", "RUN_2"]) == "run_3"


# -- (b) nothing silent ------------------------------------------------------------------------------
def _table(path: Path, header: str, rows: list[list], units: str | None = None) -> Path:
    lines = [header, *([units] if units else []), *(",".join(str(v) for v in r) for r in rows)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _rows(n=87):
    sd1 = datasets.load("SD1")
    return [[repr(float(sd1.t[k])), repr(float(sd1.u_a[k])), repr(float(sd1.i_a[k])), repr(float(sd1.omega[k]))] for k in range(n)]


def test_a_text_cell_inside_the_data_is_an_error_naming_its_line(tmp_path, capsys):
    rows = _rows()
    rows[45][2] = "abc"
    f = _table(tmp_path / "cell.csv", "t,u_a,i_a,omega", rows)
    for cols in ({"t": "0", "u_a": "1", "i_a": "2", "omega": "3"}, None):
        with pytest.raises(ValueError, match=r"line 47: field 2 \('abc'\) is not a number, inside the data that start at line 2"):
            dcjax.load_recording(f, columns=cols)
    rows[45][2] = "1.0"
    rows[60] = rows[60][:3]
    with pytest.raises(ValueError, match="line 62 has 3 field"):
        dcjax.load_recording(_table(tmp_path / "ragged.csv", "t,u_a,i_a,omega", rows))
    assert cli.main(["fit", str(f), "--columns", "t=0,u_a=1,i_a=2,omega=3", *TINY, "--out", str(tmp_path / "o")]) == 2
    assert "line 47" in one_line(capsys.readouterr().err) and not (tmp_path / "o").exists()


def test_a_unit_no_flag_converts_is_named(tmp_path):
    rows = _rows(200)
    f = _table(tmp_path / "rpm.csv", "t,u_a,i_a,speed_rpm", rows)
    with pytest.warns(
        UserWarning, match=r"column 'speed_rpm' \(omega\) is in rpm by its header, but read as rad/s: units=\{'omega': 'rpm'\} converts it"
    ):
        dcjax.load_recording(f, columns={"omega": "speed_rpm"})
    f = _table(tmp_path / "line.csv", "t,u_a,i_a,omega,temp", [r + ["21.5"] for r in rows], units="ms,V,mA,rpm,degC")
    with pytest.warns(UserWarning) as seen:
        rec = dcjax.load_recording(f)
    text = " | ".join(str(w.message) for w in seen)
    for c, u in (("t", "ms"), ("i_a", "mA"), ("omega", "rpm")):
        assert f"({c}) is in {u} by its units line" in text
    assert rec.t[1] == pytest.approx(1e-4)  # the header stayed the header: the units line is not taken for it
    f = _table(tmp_path / "unknown.csv", "t,u_a,i_a,omega", rows, units="s,V,A,krad/h")
    with pytest.warns(UserWarning, match=r"the units line gives column 'omega' \(omega\) the unit 'krad/h', which dcjax does not know"):
        dcjax.load_recording(f)
    with warnings_none():
        dcjax.load_recording(f, units={"omega": "rad/s"})  # the user said so


class warnings_none:
    """No warning inside the block."""

    def __enter__(self):
        import warnings

        self.ctx = warnings.catch_warnings()
        self.ctx.__enter__()
        warnings.simplefilter("error")

    def __exit__(self, *exc):
        self.ctx.__exit__(*exc)


def test_every_names_the_content_it_aliases(tmp_path):
    t = np.arange(1000) * 1e-3
    rec = dcjax.Recording(t=t, u_a=np.sin(2 * np.pi * 180 * t) + 1.0, i_a=np.sin(2 * np.pi * 3 * t), omega=np.cos(2 * np.pi * 3 * t))
    with pytest.warns(UserWarning, match=r"every=4 keeps 1 sample in 4: u_a has .* % of its power above the new Nyquist frequency 125 Hz"):
        dcjax.io.loading.preprocess(rec, every=4)
    with warnings_none():
        dcjax.io.loading.preprocess(datasets.load("SD1"), every=2)  # a smooth transient: nothing folds


def test_a_fit_with_no_finite_candidate_exits_non_zero(tmp_path, capsys):
    f = short_sd1(tmp_path)
    assert cli.main(["fit", str(f), *TINY, "--fix", "La=0", "--out", str(tmp_path / "o")]) == 2
    assert "no run found parameters whose simulation is finite" in one_line(capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_a_seed_beyond_int64_is_one_line_naming_it(saved, tmp_path, capsys):
    """JAX's keys take an int64; a larger seed failed inside JAX ("Python int too large")."""
    big = str(2**64 + 3)
    assert cli.main(["fit", str(saved.parent.parent / "data" / "SD1.csv"), *TINY, "--seed", big, "--out", str(tmp_path / "f")]) == 2
    assert "Search.seed must be an integer in [-2^63, 2^63), got 18446744073709551619" in one_line(capsys.readouterr().err)
    assert cli.main(["sample", str(saved), "--seed", big, "--out", str(tmp_path / "s")]) == 2
    assert "seed must be an integer in [-2^63, 2^63)" in one_line(capsys.readouterr().err)
    assert not (tmp_path / "f").exists() and not (tmp_path / "s").exists()
    with pytest.raises(dcjax.ConfigError, match=r"Search.seed must be an integer, got True"):
        dcjax.Search(seed=True)


@pytest.mark.parametrize(
    "flag,value,match",
    [
        ("--fix", "Ra=inf", "argument --fix: value of Ra must be a finite number, got 'inf'"),  # was "bounds must be finite numbers"
        ("--scale", "omega=nan", "argument --scale: value of omega must be a finite number, got 'nan'"),
        ("--bound", "Ra=0:inf", "argument --bound: Ra needs LOWER:UPPER (finite numbers), got '0:inf'"),
        ("--precision", "1,1,1,1,1,1,-inf", "argument --precision: must be comma-separated finite numbers"),
    ],
)
def test_a_flags_number_must_be_finite(tmp_path, capsys, flag, value, match):
    f = short_sd1(tmp_path)
    assert cli.main(["fit", str(f), *TINY, flag, value, "--out", str(tmp_path / "o")]) == 2
    assert match in one_line(capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_a_range_given_to_bounds_points_to_bound(tmp_path, capsys):
    """`--bounds Ra=0:10` (a range where a preset goes) said only "unknown bounds preset"."""
    f = short_sd1(tmp_path)
    assert cli.main(["fit", str(f), *TINY, "--bounds", "Ra=0:10", "--out", str(tmp_path / "o")]) == 2
    assert "--bounds takes auto or a preset, got 'Ra=0:10': a parameter's range goes in --bound NAME=LO:HI" in one_line(
        capsys.readouterr().err
    )
    assert not (tmp_path / "o").exists()


def test_result_json_is_strict_and_reads_back_inf(saved, tmp_path):
    res = dcjax.load_result(saved)
    import dataclasses

    bad = dataclasses.replace(res, run_of=np.array([np.inf]), of=float("nan"))
    text = bad.to_json(tmp_path / "r.json")
    d = json.loads(text, parse_constant=lambda c: pytest.fail(f"not strict JSON: {c}"))
    assert d["runs"][0]["of"] is None and d["of"] is None and d["format"] == "dcjax result" and d["version"] == 2
    assert dcjax.load_result(tmp_path / "r.json", recordings=[]).run_of[0] == np.inf
    assert strict_json({"a": [np.float64(np.nan), np.inf, 1.5, np.int64(3)]}, indent=None) == '{"a": [null, null, 1.5, 3]}'


def test_stats_of_a_run_with_no_finite_of_are_inf_and_nan_without_a_warning(saved):
    """Table 5's B, W, M, SD where one run found no finite OF: W and M +inf, SD not defined (NaN),
    and no NumPy warning (a result file with such a run writes its stats)."""
    import dataclasses
    import warnings

    res = dataclasses.replace(dcjax.load_result(saved), run_of=np.array([2e-10, np.inf]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        st = res.stats
    assert st["best"] == 2e-10 and st["worst"] == st["mean"] == np.inf and np.isnan(st["std"])


@pytest.mark.parametrize(
    "sidecar, match",
    [
        ({"i_a_limit": True}, "i_a_limit must be a positive number"),
        ({"i_a_limit": "5"}, "i_a_limit must be a positive number"),
        ({"name": 5}, "name must be a non-empty string"),
        ({"constants": {"kp": True}}, "constants must be an object of input name -> number"),
        ({"bounds": "nosuch"}, "the sidecar's bounds 'nosuch' is no preset: model dc has table4, table8, or auto"),
    ],
)
def test_a_sidecar_value_of_the_wrong_kind_is_an_error(tmp_path, capsys, sidecar, match):
    f = short_sd1(tmp_path)
    f.with_suffix(".json").write_text(json.dumps(sidecar))
    assert cli.main(["fit", str(f), "--runs", "1", "--budget", "140", "--plots", "none", "--out", str(tmp_path / "o")]) == 2
    assert match in one_line(capsys.readouterr().err)


def test_a_fix_outside_its_bound_is_an_error(tmp_path, capsys):
    args = ["fit", "SD1", *TINY, "--fix", "Ra=42.5", "--bound", "Ra=0:10", "--out", str(tmp_path / "o")]
    assert cli.main(args) == 2
    assert "fixed Ra=42.5 lies outside its range 0:10" in one_line(capsys.readouterr().err)


@pytest.mark.parametrize(
    "change, match",
    [
        (lambda d: d["params"].__setitem__("J", -1), r"params.J = -1 lies outside its fitted range \[0, 1\]: the file was edited"),
        (lambda d: d["params"].__setitem__("Ra", float("nan")), r"params.Ra must be a finite number, got None"),
        (lambda d: d.pop("of"), r"result.json: of is missing"),
        (lambda d: d["runs"][0].pop("of"), r"runs\[0\].of is missing"),
        (lambda d: d["checks"].append({"check": "x", "message": "m"}), r"checks\[0\].severity must be error or warning"),
        (lambda d: d["settings"].__setitem__("nd", 10**9), r"settings.nd must be an integer 1..16384, got 1000000000"),
        (lambda d: d["settings"]["bounds"].__setitem__("lower", [0]), r"settings.bounds.lower must be a list of 7 numbers"),
        (lambda d: d["settings"].__setitem__("loss", 3), r"settings: loss must be sse, l1, huber:DELTA"),
        (lambda d: d.__setitem__("version", 99), r"a result of format version 99, newer than this dcjax reads"),
    ],
)
def test_an_edited_result_is_a_one_line_error(saved, tmp_path, capsys, change, match):
    res = edited(saved, tmp_path, change)
    with pytest.raises(ValueError, match=match):
        dcjax.load_result(res)
    assert cli.main(["report", str(res)]) == 2
    one_line(capsys.readouterr().err)


def test_a_results_sizes_allocate_nothing_and_its_data_are_checked(saved, tmp_path, capsys):
    res = edited(saved, tmp_path, lambda d: d["runs"][0].__setitem__("iterations", 10**12))
    assert dcjax.load_result(res).history.shape == (1, 1)
    data = tmp_path / "data" / "SD1.csv"
    data.write_text(data.read_text().replace("0.0001,", "0.00010,", 1))  # the same numbers, other bytes
    with pytest.warns(UserWarning, match=r"its data file .*SD1.csv changed since the fit \(its size differs\): loaded without it"):
        assert dcjax.load_result(res).recordings == []
    assert cli.main(["report", str(res), "--uncertainty"]) == 2
    assert "no recording" in one_line(capsys.readouterr().err)
    assert cli.main(["report", str(res), "--uncertainty", "--allow-changed-data"]) == 0
    assert cli.main(["report", str(res), "--uncertainty", "--data", str(data)]) == 0
    other = edited(saved, tmp_path / "other", lambda d: d["settings"]["data"][0].__setitem__("path", "/etc/hostname"))
    with pytest.warns(UserWarning, match=r"its data file /etc/hostname (changed since the fit|is not there)"):
        assert dcjax.load_result(other).recordings == []  # another file is never parsed (nor shown in an error)
    moved = tmp_path / "elsewhere"
    shutil.copytree(tmp_path / "fit", moved / "fit")  # a result moved without its data: said, not guessed
    with pytest.warns(UserWarning, match="is not there: loaded without it"):
        dcjax.load_result(moved / "fit" / "result.json")


def test_a_nan_is_named_by_its_line_and_a_header_only_file_by_what_it_is(tmp_path):
    rows = _rows(120)
    rows[54][3] = "nan"
    f = _table(tmp_path / "nan.csv", "# a comment\nt,u_a,i_a,omega", rows)
    with pytest.raises(dcjax.io.recording.DataError, match=r"nan.csv: line 57: omega is NaN"):
        dcjax.load_recording(f)
    (tmp_path / "h.csv").write_text("t,u_a,i_a,omega\n")
    with pytest.raises(ValueError, match="no data rows: the file holds 1 line"):
        dcjax.load_recording(tmp_path / "h.csv")
    (tmp_path / "big.txt").write_bytes(b"not a table at all\n" * 200_000)  # 3.8 MB of text: refused from its tail
    with pytest.raises(ValueError, match="cannot detect the delimiter"):
        dcjax.load_recording(tmp_path / "big.txt")


# -- (c) outputs written whole, one writer a folder -------------------------------------------------
def test_an_output_folder_has_one_writer_and_keeps_an_earlier_run(tmp_path):
    earlier = lambda f: [f / "result.json"]
    with OutputFolder(tmp_path / "out", earlier) as a, OutputFolder(tmp_path / "out", earlier) as b:
        assert a.path == tmp_path / "out" and b.path == tmp_path / "out-2" and "another dcjax process" in (b.note or "")
        with pytest.raises(OSError, match="another dcjax process is writing it"), OutputFolder(tmp_path / "out", earlier, overwrite=True):
            pass
        (a.path / "result.json").write_text("{}")
    assert not (tmp_path / "out-2").exists()  # created, nothing written into it: removed
    with OutputFolder(tmp_path / "out", earlier) as c:
        assert c.path == tmp_path / "out-2" and "holds" in (c.note or "")
    with OutputFolder(tmp_path / "out", earlier, overwrite=True) as d:
        assert d.path == tmp_path / "out" and d.replaced == [tmp_path / "out" / "result.json"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(OSError, match="is a file"), OutputFolder(tmp_path / "file", earlier):
        pass
    with pytest.raises(OSError, match="cannot write there"), OutputFolder(tmp_path / "file" / "sub", earlier):
        pass
    with pytest.raises(RuntimeError), OutputFolder(tmp_path / "new", earlier):
        raise RuntimeError("failed before writing")
    assert not (tmp_path / "new").exists()  # nothing written: no folder left behind


def test_a_fit_stopped_while_writing_never_leaves_a_result_beside_another_runs_plot(tmp_path, monkeypatch, capsys):
    f = short_sd1(tmp_path)
    out = tmp_path / "o"
    assert cli.main(["fit", str(f), "--bounds", "table4", "--runs", "1", "--budget", "140", "--out", str(out)]) == 0
    assert cli.main(["fit", str(f), "--bounds", "table4", "--runs", "1", "--budget", "140", "--out", str(out)]) == 0
    assert (tmp_path / "o-2" / "result.json").is_file() and "writing to" in capsys.readouterr().err  # the earlier one kept
    old_plot = (out / "fit.png").read_bytes()

    def killed(self, path=None, files=None):
        raise KeyboardInterrupt  # stopped between the plot and result.json

    monkeypatch.setattr(dcjax.FitResult, "to_json", killed)
    with pytest.raises(KeyboardInterrupt):
        cli.main(["fit", str(f), "--bounds", "table4", "--runs", "1", "--budget", "70", "--seed", "3", "--out", str(out), "--overwrite"])
    assert not (out / "result.json").exists() and (out / "fit.png").read_bytes() != old_plot
    assert not list(out.glob(".*.tmp-*"))


def test_each_again_replaces_its_earlier_folders_only_with_overwrite(tmp_path):
    files = [str(short_sd1(tmp_path / "d", f"r{k}", n=120)) for k in range(3)]
    out = tmp_path / "each"
    assert cli.main(["fit", "--each", *files, *TINY, "--out", str(out)]) == 0
    assert cli.main(["fit", "--each", *files[:1], *TINY, "--out", str(out), "--overwrite"]) == 0
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["r0"]  # no stale folder beside a summary that lists one
    assert "folder" in (out / "summary.csv").read_text().splitlines()[0]


def test_an_odrive_export_reads_as_it_comes(tmp_path):
    """The ODrive motor characterisation export: a `%` preamble, the header and the units line as
    `%` comments, CRLF, `;` ending every line, rows of `nan` between the data."""
    sd1 = datasets.load("SD1")
    lines = ["% ODrive motor characterisation export", "% axis0, firmware v0.5.6", "%timestep (8Hz),voltage,position,velocity",
             "%[#],[V],[turns],[turns/s]"]  # fmt: skip
    for k in range(120):
        lines.append(f"{k},{float(sd1.u_a[k])!r},{0.01 * k!r},{float(sd1.omega[k]) / (2 * np.pi)!r};")
        if k in (30, 31, 77):
            lines.append("nan,nan,nan,nan;")
    f = tmp_path / "odrive.csv"
    f.write_bytes(("\r\n".join(lines) + "\r\n").encode())
    speed_only = dcjax.DC().measuring(("omega",))
    with pytest.warns(UserWarning) as seen:
        rec = dcjax.load_recording(f, columns={"t": "0", "u_a": "1", "omega": "3"}, drop_nan=True, model=speed_only)
    said = " | ".join(str(w.message) for w in seen)
    assert "dropped 3 of 123 rows" in said and "(omega) is in turns/s by its units line" in said and "the unit '#'" in said
    assert len(rec) == 120 and rec.omega[5] == pytest.approx(sd1.omega[5] / (2 * np.pi))
    named = dcjax.load_recording(f, columns={"t": "timestep (8Hz)", "u_a": "voltage", "omega": "velocity"}, units={"t": "s", "omega": "turns/s"},
                                 drop_nan=True, model=speed_only)  # the header of the comment line  # fmt: skip
    np.testing.assert_allclose(named.omega, rec.omega * 2 * np.pi)


@pytest.mark.slow
def test_nd_auto_takes_md1_with_its_fitted_starts(tmp_path):
    """Paper Section 5's automatic ND on MD1 (a guide's command), whose noisy channels start
    fitted by default: it refused them; now its reference starts from the fitted state."""
    out = tmp_path / "o"
    assert cli.main(["fit", str(datasets.DATA_DIR / "MD1.csv"), "--runs", "2", "--budget", "14000", "--nd", "auto", "--bounds", "table8", "--offset", "i_a",
                     "--plots", "none", "--out", str(out)]) == 0  # fmt: skip
    res = dcjax.load_result(out / "result.json")
    assert res.settings["nd_auto"]["chosen"] == res.settings["nd"] and {"y0_i_a", "y0_omega"} <= set(res.names)


# -- subprocesses: two writers at once, an interrupt ---------------------------------------------------
def _dcjax(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "dcjax", *args], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "DCJAX_NO_CACHE": "1"}, **kw)  # fmt: skip


@pytest.mark.slow
def test_two_fits_into_one_out_are_both_whole_and_distinct(tmp_path):
    out = tmp_path / "out"
    procs = [_dcjax("fit", "data/SD1.csv", *TINY, "--budget", "14000", "--seed", str(s), "--out", str(out)) for s in (1, 2)]
    for p in procs:
        p.communicate(timeout=300)
        assert p.returncode == 0
    seeds = {dcjax.load_result(f / "result.json").settings["seed"] for f in (out, tmp_path / "out-2")}
    assert seeds == {1, 2}


@pytest.mark.slow
def test_an_interrupt_ends_with_one_line_and_leaves_nothing_half_written(tmp_path):
    out = tmp_path / "out"
    p = _dcjax(  # SIGINT as a terminal gives it, also where this runs as a background job (which inherits it ignored)
        "fit", "data/SD1.csv", "--bounds", "table4", "--runs", "50", "--budget", "1000000", "--out", str(out),
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    import time

    t = time.perf_counter()  # the command has started once it holds its --out (its imports done: a SIGINT that lands
    while not out.exists() and time.perf_counter() - t < 60:  # in one of jax's gc callbacks while Python imports is lost)
        time.sleep(0.1)
    time.sleep(3)  # in the search (the compiled call that returns to Python at its end)
    t = time.perf_counter()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert time.perf_counter() - t < 2.0 and p.returncode == 128 + signal.SIGINT, (p.returncode, err[-1500:])
    assert err.strip().splitlines()[-1].startswith("dcjax: interrupted") and "Traceback" not in err
    assert not out.exists()  # created by this run, nothing written into it: removed


# -- generated variants ------------------------------------------------------------------------------
def _leaves(d, prefix=()):
    """Every path into a JSON object (objects and lists, to depth 4)."""
    out = []
    items = d.items() if isinstance(d, dict) else enumerate(d) if isinstance(d, list) else ()
    for k, v in items:
        out.append((*prefix, k))
        if len(prefix) < 3:
            out += _leaves(v, (*prefix, k))
    return out


def test_random_edits_of_a_result_load_or_fail_in_one_line(saved, tmp_path):
    """300 seeded edits of result.json (a field removed, or set to a string, a list, an object,
    null, NaN, a boolean, a huge or a negative number): each loads and reports, or is a one-line
    ValueError; never another exception, never a traceback's worth of text."""
    import copy
    import warnings

    rng = np.random.default_rng(51)
    shutil.copytree(saved.parent.parent, tmp_path, dirs_exist_ok=True)
    path = tmp_path / "fit" / "result.json"
    d0 = json.loads(saved.read_text())
    paths = _leaves(d0)
    values = ["x", [], {}, None, float("nan"), True, 1e300, -1, 10**18, "../../etc/passwd", "os:system"]
    outcomes = {"loaded": 0, "refused": 0}
    for _ in range(300):
        d = copy.deepcopy(d0)
        where = paths[rng.integers(len(paths))]
        parent = d
        for key in where[:-1]:
            parent = parent[key]
        if rng.random() < 0.3 and isinstance(parent, dict):
            del parent[where[-1]]
        else:
            parent[where[-1]] = values[rng.integers(len(values))]
        path.write_text(json.dumps(d))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = dcjax.load_result(path)
                res.report()
            outcomes["loaded"] += 1
        except ValueError as e:
            assert "\n" not in str(e) and len(str(e)) < 400, (where, str(e))
            outcomes["refused"] += 1
    assert outcomes["loaded"] > 20 and outcomes["refused"] > 40, outcomes  # many edits touch what a reader recomputes (stats, parameters)


def test_random_damage_to_a_table_reads_every_row_or_names_the_line(tmp_path):
    """200 seeded kinds of damage to a 60-row CSV (a cell replaced by text, a missing or an empty
    field, a field too many, a line of text, of NaN, a blank line, a comment, the header again):
    each file reads all 60 rows exactly, or is a one-line ValueError naming the file; a row is
    never skipped in silence."""
    import warnings

    rng = np.random.default_rng(7)
    rows = _rows(60)
    want = np.array([[float(v) for v in r] for r in rows])
    tokens = ["abc", "", "nan", "1e", "--", "1,5", "inf", "NA", "0x10"]
    for k in range(200):
        lines = ["t,u_a,i_a,omega", *(",".join(r) for r in rows)]
        at = int(rng.integers(1, len(lines)))
        kind = int(rng.integers(8))
        fields = lines[at].split(",")
        if kind == 0:
            fields[rng.integers(4)] = tokens[rng.integers(len(tokens))]
            lines[at] = ",".join(fields)
        elif kind == 1:
            lines[at] = ",".join(fields[:3])
        elif kind == 2:
            lines[at] = ",".join([*fields, "1.0"])
        elif kind == 3:
            lines.insert(at, "recorded on bench 4")
        elif kind == 4:
            lines.insert(at, "nan,nan,nan,nan")
        elif kind == 5:
            lines.insert(at, "")
        elif kind == 6:
            lines.insert(at, "# a note")
        else:
            lines.insert(at, lines[0])
        f = tmp_path / f"damaged{k}.csv"
        f.write_text("\n".join(lines) + "\n")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rec = dcjax.load_recording(f)
        except ValueError as e:
            assert f.name in str(e) and "\n" not in str(e), str(e)
            assert kind not in (5, 6), (kind, str(e))  # a blank line or a comment is no damage
            continue
        got = np.column_stack([rec.t, rec.u_a, rec.i_a, rec.omega])
        np.testing.assert_array_equal(got, want, err_msg=f"kind {kind} at line {at + 1}")


def test_the_command_line_shows_its_flags_where_the_library_names_its_arguments(tmp_path, capsys):
    """A library message names Python arguments (`units={'omega': 'rpm'}`); the command line
    prints its own flags (`dcjax.cli.flags.as_flags`, one table)."""
    from dcjax.cli.flags import as_flags

    assert as_flags("units={'omega': 'rpm'} converts it") == "--units omega=rpm converts it"
    assert as_flags("drop_nan=True drops such rows; give params['y0_omega'].set(min=LO, max=HI)") == (
        "--drop-nan drops such rows; give --bound y0_omega=LO:HI"
    )
    assert as_flags("constants={'k': V}, dt= or rate=; initial={'iq': 'measured'}") == "--const k=V, --dt or --rate; --initial iq=measured"
    # a value a shell would split or read as syntax is quoted, so that the printed flag runs as it is
    assert as_flags("map it with columns={'t': 't [ms]'}; give delimiter=';'") == "map it with --columns 't=t [ms]'; give --delimiter ';'"
    h = _table(tmp_path / "ms.csv", "t [ms],u_a,i_a,omega", _rows(200))
    assert cli.main(["fit", str(h), *TINY, "--out", str(tmp_path / "m")]) == 2
    assert "--columns 't=t [ms]' and --units t=ms" in capsys.readouterr().err
    f = _table(tmp_path / "rpm.csv", "t,u_a,i_a,speed_rpm", _rows(200))
    assert cli.main(["fit", str(f), "--columns", "omega=speed_rpm", "--fix", "La=0", *TINY, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--units omega=rpm converts it" in err and "units={" not in err


def test_a_flag_of_pairs_given_twice_adds_to_them_and_never_drops_one():
    """`--bound Ra=0:10 --bound J=0:0.1` is `--bound Ra=0:10,J=0:0.1` (argparse kept the last
    alone: a model file's every range given flag by flag still ran the auto estimate, which
    could not, and said to give the ranges); names add up too; a pair given twice with two
    values, or numbers given twice, is a one-line error; a plain value keeps the last."""
    from dcjax.cli.parser import build_parser

    p = build_parser()
    a = p.parse_args(["fit", "x.csv", "--bound", "Ra=0:10", "--bound", "J=0:0.1", "--log", "Tlb", "--log", "Tlc,Tlb", "--fix", "Tlc=0"])
    assert a.bound == {"Ra": (0.0, 10.0), "J": (0.0, 0.1)} and a.log == ("Tlb", "Tlc") and a.fix == {"Tlc": 0.0}
    assert p.parse_args(["fit", "x.csv", "--units", "t=ms", "--units", "t=ms,omega=rpm"]).units == {"t": "ms", "omega": "rpm"}
    with pytest.raises(dcjax.ConfigError, match=r"^argument --bound: Ra given twice \(\(0.0, 10.0\) and \(1.0, 10.0\)\)$"):
        p.parse_args(["fit", "x.csv", "--bound", "Ra=0:10", "--bound", "Ra=1:10"])
    with pytest.raises(dcjax.ConfigError, match="argument --weights: given twice"):
        p.parse_args(["fit", "x.csv", "--weights", "1,1", "--weights", "2,2"])
    assert p.parse_args(["fit", "x.csv", "--runs", "4", "--runs", "8"]).runs == 8
