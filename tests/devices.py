"""Run a snippet in a fresh Python process with several XLA CPU devices (a device count is fixed
when JAX starts, so a test of another count needs its own process)."""

import json
import os
import subprocess
import sys


def on_devices(code: str, devices: int = 2) -> dict:
    """The JSON object that `code`'s last printed line holds, run with `devices` host devices."""
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])
