"""The persistent compilation cache of the `dcjax` command: a second identical fit in a new
process loads its executables; `DCJAX_NO_CACHE=1` turns it off."""

import json
import os
import subprocess
import sys

import pytest


def _fit(tmp_path, out, **env):
    env = {**{k: v for k, v in os.environ.items() if k != "DCJAX_NO_CACHE"}, **env}
    cmd = [sys.executable, "-m", "dcjax", "fit", "SD1", "--runs", "2", "--budget", "1400", "--out", str(tmp_path / out)]
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    return json.loads((tmp_path / out / "result.json").read_text())


@pytest.mark.slow
def test_second_identical_fit_compiles_from_the_cache(tmp_path):
    cache = tmp_path / "cache"
    first = _fit(tmp_path, "a", DCJAX_CACHE_DIR=str(cache))
    entries = set(cache.iterdir())
    assert entries
    second = _fit(tmp_path, "b", DCJAX_CACHE_DIR=str(cache))
    assert second["runs"] == first["runs"]
    # Every executable is cached (min_compile_seconds=0), so one compiled again would be a new
    # entry: the second process compiled nothing (its tracing and lowering remain, ~0.4 s here).
    assert set(cache.iterdir()) == entries


@pytest.mark.slow
def test_cache_can_be_turned_off(tmp_path):
    cache = tmp_path / "cache"
    _fit(tmp_path, "a", DCJAX_CACHE_DIR=str(cache), DCJAX_NO_CACHE="1")
    assert not cache.exists() or not any(cache.iterdir())
