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
    assert any(cache.iterdir())
    second = _fit(tmp_path, "b", DCJAX_CACHE_DIR=str(cache))
    assert second["runs"] == first["runs"]
    # Tracing and lowering remain (~0.4 s here); the XLA compilation itself is skipped.
    assert second["timing"]["compile_s"] < 0.5 * first["timing"]["compile_s"], (first["timing"], second["timing"])


@pytest.mark.slow
def test_cache_can_be_turned_off(tmp_path):
    cache = tmp_path / "cache"
    _fit(tmp_path, "a", DCJAX_CACHE_DIR=str(cache), DCJAX_NO_CACHE="1")
    assert not cache.exists() or not any(cache.iterdir())
