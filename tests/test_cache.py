"""The persistent compilation cache of the `dcjax` command: a second identical fit in a new
process loads its executables; `DCJAX_NO_CACHE=1` turns it off; called in a process, the command
leaves that process's own cache settings as they were."""

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


CALLED_IN_A_PROCESS = """
import os, sys
import jax, jax.numpy as jnp
import dcjax.cli

command, own = sys.argv[1], sys.argv[2]
settings = lambda: (jax.config.jax_compilation_cache_dir, jax.config.jax_persistent_cache_min_compile_time_secs)
count = lambda folder: len([n for n in os.listdir(folder) if n.endswith("-cache")]) if os.path.isdir(folder) else 0
before, own_before = settings(), count(own)
assert dcjax.cli.main(["fit", "SD1", "--runs", "1", "--budget", "700", "--plots", "none", "--out", sys.argv[3]]) == 0
assert settings() == before, (settings(), before)
written = count(command)
assert written > 0  # the command cached its programs
assert count(own) == own_before  # and nothing to the caller's own folder
jax.jit(lambda x: jnp.sin(x) * 3.0)(jnp.ones(5)).block_until_ready()
assert count(command) == written  # the caller's programs after it are not the command's to cache
assert (count(own) > own_before > 0) if sys.argv[4] == "own" else count(own) == 0  # the caller's folder, opened before: written to again
print("ok")
"""


@pytest.mark.parametrize("caller", ["none", "own"])
def test_the_command_in_a_process_leaves_its_cache_settings_as_they_were(tmp_path, caller):
    env = {k: v for k, v in os.environ.items() if k not in ("DCJAX_NO_CACHE", "XLA_FLAGS")}
    env["DCJAX_CACHE_DIR"] = str(tmp_path / "command")
    own = tmp_path / "own"
    script = CALLED_IN_A_PROCESS
    if caller == "own":  # the caller's own cache, every program, one compiled before the command
        script = (
            "import jax, jax.numpy as jnp, sys\n"
            "jax.config.update('jax_compilation_cache_dir', sys.argv[2])\n"
            "jax.config.update('jax_persistent_cache_min_compile_time_secs', 0.0)\n"
            "jax.jit(lambda x: jnp.tan(x) * 2.0)(jnp.ones(5)).block_until_ready()\n" + script
        )
    args = [sys.executable, "-c", script, str(tmp_path / "command"), str(own), str(tmp_path / "out"), caller]
    out = subprocess.run(args, capture_output=True, text=True, env=env)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-2000:]
