import os

import jax
import pytest

# The CLI turns on JAX's persistent compilation cache in the user's cache folder; tests call it
# in-process and spawn it, so keep it off (tests/test_cache.py turns it on in a temporary folder).
os.environ.setdefault("DCJAX_NO_CACHE", "1")

import dcjax
from dcjax import datasets

# The XLA setting the CLI and the experiments run with (`dcjax.use_compiled_loops`: a time loop
# compiled as one function), so that in-process tests run what users run; in this test process
# only, before any JAX computation (subprocess tests that check the default remove XLA_FLAGS).
dcjax.use_compiled_loops()


@pytest.fixture(scope="session")
def sd1():
    return datasets.load("SD1")


@pytest.fixture(scope="session")
def sd1_true():
    return dict(datasets.true_params("SD1"))


def pytest_configure(config):
    assert jax.config.jax_enable_x64, "dcjax must enable float64"
