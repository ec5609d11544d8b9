"""The reproduction machinery: the store survives kills, the plan has the paper's grid, the smoke
profile runs end to end, and an interrupted run resumes to the same report."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "experiments"))

from cells import Cell, Store  # noqa: E402
from report import without_times  # noqa: E402


def test_store_ignores_torn_lines_and_unfinished_cells(tmp_path):
    s = Store(tmp_path / "s.jsonl")
    a, b = Cell("SD1", runs=2), Cell("SD2", runs=2)
    run = lambda c, k: {"key": c.key, "run": k, "of": float(k)}
    s.append([run(a, 0), run(a, 1), {"key": a.key, "complete": True, "runs": 2, "run_s": 1.0, "compile_s": 0.0}])
    s.append([run(b, 0)])  # killed before its second run and completion line
    with open(s.path, "a") as f:
        f.write('{"key": "torn li')  # killed mid-write
    assert list(s.cells()) == [a.key]  # b unfinished, the torn line ignored
    s.append([run(b, 0), run(b, 1), {"key": b.key, "complete": True, "runs": 2, "run_s": 1.0, "compile_s": 0.0}])  # the redo
    cells = s.cells()
    assert [r["of"] for r in cells[a.key]["runs"]] == [0.0, 1.0]
    assert [r["run"] for r in cells[b.key]["runs"]] == [0, 1]


def _plan(overrides):
    from hydra import compose, initialize_config_dir
    from reproduce import plan

    with initialize_config_dir(config_dir=str(ROOT / "experiments" / "conf"), version_base="1.3"):
        return plan(compose(config_name="reproduce", overrides=overrides))


def test_full_plan_has_the_papers_grid():
    cells = _plan([])
    by = lambda **kw: [c for c in cells if all(getattr(c, k) == v for k, v in kw.items())]
    assert len(by(data="SD1", memory=None)) == 5 and all(c.runs == 50 and c.budget == 140_000 for c in by(data="SD3"))
    assert len([c for c in cells if c.data.startswith("SD")]) == 20  # Table 5: 4 x 5
    assert len(by(data="MD2", memory=None, generations=None, runs=50, w1=1.0)) == 5 * 2 + 4  # Tables 11-12 + EM5..RK10
    assert len([c for c in by(data="MD4") if c.w1 != 1.0]) == 9  # Table 23
    mem = [c for c in cells if c.memory]
    assert len(mem) == 4 * 6 * 3 and {c.generations for c in mem} == {1999}  # Tables 30-33
    assert all(c.runs == 50 for c in mem if c.memory == "stma")
    assert len(cells) == len(set(cells))


def test_unknown_suite_is_an_error():
    with pytest.raises(ValueError, match="unknown suites"):
        _plan(["suites=[tables]"])


def _reproduce(tmp, *extra, wait=True):
    cmd = [
        sys.executable,
        str(ROOT / "experiments" / "reproduce.py"),
        "profile=smoke",
        f"store={tmp}/store.jsonl",
        f"report={tmp}/REPORT.md",
        f"figures={tmp}/figures",
        f"hydra.run.dir={tmp}/hydra",
        *extra,
    ]
    if wait:
        return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900)
    return subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_smoke_profile_end_to_end(tmp_path):
    out = _reproduce(tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    text = (tmp_path / "REPORT.md").read_text()
    for heading in ("Tables 5 and 6", "Tables 9–17", "Tables 20–23", "Tables 24–28", "Tables 30–33"):
        assert heading in text
    assert text.count("**Verdict") >= 6 and (tmp_path / "figures" / "fig25_memory_times.png").is_file()
    again = _reproduce(tmp_path)  # everything is in the store: nothing recomputed, same report
    assert "computed 0 cells" in again.stdout and (tmp_path / "REPORT.md").read_text() == text


SMALL = "suites=[table5]"  # two cells (DE/rand/1/exp and TLBO on SD1): enough to stop between and inside cells


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    ref = tmp_path_factory.mktemp("reference")
    out = _reproduce(ref, SMALL)
    assert out.returncode == 0, out.stderr[-3000:]
    return ref


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_interrupted_reproduction_resumes_to_the_same_report(tmp_path, sig, uninterrupted):
    proc = _reproduce(tmp_path, SMALL, wait=False)
    store = Store(tmp_path / "store.jsonl")
    t0 = time.time()
    while not store.cells() and time.time() - t0 < 300:
        time.sleep(0.1)
    os.kill(proc.pid, sig)  # the second cell is now being compiled or run
    proc.wait(timeout=60)
    done = len(store.cells())
    assert done == 1, "the kill should land inside the second cell"
    resumed = _reproduce(tmp_path, SMALL)
    assert resumed.returncode == 0 and "1 already in" in resumed.stdout and "computed 1 cells" in resumed.stdout
    assert without_times((tmp_path / "REPORT.md").read_text()) == without_times((uninterrupted / "REPORT.md").read_text())
    lines = (tmp_path / "store.jsonl").read_text().splitlines()
    assert sum(1 for x in lines if x.startswith("{") and json.loads(x).get("complete")) == 2
