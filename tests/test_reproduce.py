"""The reproduction machinery: the store survives kills, the plan has the paper's grid, the smoke
profile runs end to end, and an interrupted run resumes to the same report."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from experiments.cells import Cell, Store, recording
from experiments.report import load_profile, without_times, write_report

ROOT = Path(__file__).resolve().parent.parent


def test_store_ignores_torn_lines(tmp_path):
    s = Store(tmp_path / "s.jsonl")
    a, b = Cell("SD1", runs=2), Cell("SD2", runs=2)
    line = lambda c: {"key": c.key, "of": [0.0, 1.0], "params": [[0.0] * 7] * 2, "run_s": 1.0, "compile_s": 0.0}
    s.append(line(a))
    with open(s.path, "a") as f:
        f.write('{"key": "torn li')  # killed mid-write of b's line
    assert list(s.cells()) == [a.key]
    s.append(line(b))  # the redo starts on a fresh line
    s.append({"event": "reproduce", "cells_planned": 2, "cells_computed": 1})
    assert list(s.cells()) == [a.key, b.key] and s.cells()[a.key]["of"] == [0.0, 1.0]
    assert [e["cells_computed"] for e in s.events()] == [1]


def test_lab_ablation_case_regenerates_the_data_file():
    for name in ("MD1", "MD4"):
        a, b = recording(name), recording(name, "lab")
        assert np.array_equal(a.t, b.t) and np.array_equal(a.i_a, b.i_a) and np.array_equal(a.omega, b.omega)
        fast = recording(name, "clean-sampling-11x")  # holds every original sample instant
        assert np.isin(np.round(a.t, 9), np.round(fast.t, 9)).all() and len(fast.t) > 10 * len(a.t)
    with pytest.raises(ValueError, match="unknown ablation case"):
        recording("MD1", "windy")


def _plan(overrides):
    from hydra import compose, initialize_config_dir

    from experiments.reproduce import plan

    with initialize_config_dir(config_dir=str(ROOT / "experiments" / "conf"), version_base="1.3"):
        return plan(compose(config_name="reproduce", overrides=overrides))


def test_full_plan_has_the_papers_grid():
    cells = _plan([])
    by = lambda **kw: [c for c in cells if all(getattr(c, k) == v for k, v in kw.items())]
    assert len(by(data="SD1", memory=None, bounds_rule="", init_rule="")) == 5 and all(
        c.runs == 50 and c.budget == 140_000 for c in by(data="SD3")
    )
    assert len([c for c in cells if c.data.startswith("SD") and not (c.bounds_rule or c.init_rule)]) == 20  # Table 5: 4 x 5
    assert len(by(data="MD2", memory=None, generations=None, runs=50, w1=1.0)) == 5 * 2 + 4  # Tables 11-12 + EM5..RK10
    assert len([c for c in by(data="MD4") if c.w1 != 1.0]) == 9  # Table 23
    mem = [c for c in cells if c.memory]
    assert len(mem) == 4 * 6 * 2 and {c.generations for c in mem} == {1999}  # Tables 30-33: STMA, LTMA (index)
    assert all(c.runs == 50 for c in mem)
    assert len([c for c in cells if c.bounds_rule or c.init_rule]) == 5  # 3 rules x 2 inits, the default in Table 5
    assert {c.case for c in cells if c.case} >= {"clean", "lab", "noise", "armature", "static"}
    assert any(c.fixed == "Tlc=0" for c in cells) and any(c.data == "MD1+MD2+MD3" and c.polish for c in cells)
    assert len(cells) == len(set(cells))


def test_unknown_suite_is_an_error():
    with pytest.raises(ValueError, match="unknown suites"):
        _plan(["suites=[tables]"])


def _command(tmp, *extra) -> list[str]:
    cmd = [
        sys.executable,
        "-W",
        "error::DeprecationWarning",  # the package's own paths use no deprecated name
        "-m",
        "experiments.reproduce",
        "profile=smoke",
        f"store={tmp}/store.jsonl",
        f"report={tmp}/REPORT.md",
        f"figures={tmp}/figures",
        f"hydra.run.dir={tmp}/hydra",
        *extra,
    ]
    return cmd


def _reproduce(tmp, *extra) -> subprocess.CompletedProcess[str]:
    return subprocess.run(_command(tmp, *extra), cwd=ROOT, capture_output=True, text=True, timeout=900)


def _start_reproduce(tmp, *extra) -> subprocess.Popen:
    # SIGINT as a terminal gives it, also where the tests run as a background job (which inherits it ignored, and
    # Python then ignores it: the run went on to its end)
    return subprocess.Popen(
        _command(tmp, *extra),
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


@pytest.mark.slow
def test_smoke_profile_end_to_end(tmp_path):
    out = _reproduce(tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    text = (tmp_path / "REPORT.md").read_text()
    for heading in ("Tables 5 and 6", "Tables 9–17", "Tables 20–23", "Tables 24–28", "Tables 30–33", "ablation", "Bound handling"):
        assert heading in text
    assert text.count("**Verdict") >= 15 and (tmp_path / "figures" / "fig25_memory_times.png").is_file()
    assert "One uninterrupted run" in text
    # the report is a function of the store, byte for byte (in this process: `python -m experiments.report` is its argparse);
    # that a stored cell is not computed again is test_interrupted_reproduction_resumes_to_the_same_report's "1 already in"
    write_report(f"{tmp_path}/store.jsonl", f"{tmp_path}/R2.md", f"{tmp_path}/figures", {"profile": load_profile("smoke"), "seed": 0})
    assert (tmp_path / "R2.md").read_text() == text


SMALL = "suites=[table5]"  # two cells (DE/rand/1/exp and TLBO on SD1): enough to stop between and inside cells


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    ref = tmp_path_factory.mktemp("reference")
    out = _reproduce(ref, SMALL)
    assert out.returncode == 0, out.stderr[-3000:]
    return ref


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_interrupted_reproduction_resumes_to_the_same_report(tmp_path, sig, uninterrupted):
    proc = _start_reproduce(tmp_path, SMALL, "pause_s=2")  # 2 s before each cell: the kill (within 0.1 s of the first) lands in the second
    store = Store(tmp_path / "store.jsonl")
    t0 = time.time()
    while not store.cells() and time.time() - t0 < 300:
        time.sleep(0.1)
    os.kill(proc.pid, sig)  # the second cell is now waiting its 2 s
    proc.wait(timeout=60)
    done = len(store.cells())
    assert done == 1, "the kill should land inside the second cell"
    resumed = _reproduce(tmp_path, SMALL)
    assert resumed.returncode == 0 and "1 already in" in resumed.stdout and "computed 1 cells" in resumed.stdout
    text = (tmp_path / "REPORT.md").read_text()
    assert without_times(text) == without_times((uninterrupted / "REPORT.md").read_text())
    assert "not one uninterrupted run" in text  # the report says the store took two invocations
    lines = (tmp_path / "store.jsonl").read_text().splitlines()
    assert sum(1 for x in lines if x.startswith("{") and "of" in json.loads(x)) == 2


def test_time_verdicts_cannot_flip_within_the_measured_spread():
    """Two runs whose time ratios differ by less than time_spread^2 (the run-to-run spread measured
    here) never give one cell opposite sides, nor a verdict its opposite: at worst "not decided"."""
    from experiments.report.thresholds import T, time_side, time_verdict

    rng = np.random.default_rng(0)
    spread = 2 * np.log(T["time_spread"])
    for _ in range(500):
        r = np.exp(rng.uniform(-1.2, 1.2, 16))
        r2 = r * np.exp(rng.uniform(-spread, spread, 16))
        a, b = ([time_side(x, 1 / 1.5, 1.5) for x in rs] for rs in (r, r2))
        assert all({x, y} != {"in", "out"} for x, y in zip(a, b))
        v, w = time_verdict(a), time_verdict(b)
        assert v == w or "not decided" in v or "not decided" in w, (v, w)
    assert time_verdict(["in", "in"]) == "reproduced" and time_verdict(["out", "out"]) == "differs"
    assert time_verdict(["in", "near"]).startswith("not decided")  # "reproduced" if near is in, "qualitatively" if out
    assert time_verdict(["in", "in", "in", "near", "out"]) == "reproduced qualitatively"  # 3/5 or 4/5 in: the same word
