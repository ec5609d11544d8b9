"""Run a snippet in a fresh Python process with several XLA CPU devices (a device count is fixed
when JAX starts, so a test of another count needs its own process)."""

import json
import os
import re
import subprocess
import sys


def on_devices(code: str, devices: int = 2) -> dict:
    """The JSON object that `code`'s last printed line holds, run with `devices` host devices
    and this session's compiled loops (`conftest.py`: what the `dcjax` command runs)."""
    loops = re.search(r"--xla_backend_extra_options=\S+", os.environ.get("XLA_FLAGS", ""))
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices} {loops.group(0) if loops else ''}".strip())
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])
