"""dcjax: DC motor and drive parameter identification in JAX.

Implements Jesenik, Hamler, Trbušić, Trlep, "The Use of Evolutionary Methods for the
Determination of a DC Motor and Drive Parameters Based on the Current and Angular Speed
Response", Mathematics 2020, 8, 1269.

Importing dcjax enables ``jax_enable_x64``: the paper's best objective values are ~1e-19,
which float32 cannot resolve. It also asks XLA for one CPU device per core (unless XLA_FLAGS
already sets ``--xla_force_host_platform_device_count``) so that independent runs are sharded.
"""

import os

# One XLA host device per core, so `identify` can shard independent runs across them (on a
# 2-core CPU this halves the wall time). Only when the user has not set the flag, and only
# effective if no JAX computation ran before `import dcjax`.
if "xla_force_host_platform_device_count" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={os.cpu_count() or 1}"
    ).strip()

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

from .bounds import TABLE4, TABLE8, Bounds, bounds_preset  # noqa: E402
from .objectives import Problem, make_problem, objective, residuals  # noqa: E402
from .params import PARAM_NAMES, Params  # noqa: E402
from .recording import Recording, load_csv, save_csv, trim_switch_on  # noqa: E402
from .identify import IdentificationResult, identify  # noqa: E402
from .integrate import simulate  # noqa: E402

__all__ = [
    "PARAM_NAMES",
    "Params",
    "Bounds",
    "TABLE4",
    "TABLE8",
    "bounds_preset",
    "Recording",
    "load_csv",
    "save_csv",
    "trim_switch_on",
    "Problem",
    "make_problem",
    "simulate",
    "objective",
    "residuals",
    "identify",
    "IdentificationResult",
]
