import collections
import os
import shutil
import tempfile

import jax
import pytest

import dcjax
from dcjax import datasets

# One persistent compilation cache for this test session, in a temporary folder shared by the
# xdist workers (they inherit the environment of the process that imports this first) and by the
# commands the tests spawn: a program compiled by one test is loaded by every other that builds
# the same one (most of the suite's time is compilation). The user's own cache is never touched;
# tests/test_cache.py checks the cache itself in folders of its own.
_OWN_CACHE = "DCJAX_TEST_CACHE_DIR" not in os.environ
if _OWN_CACHE:
    os.environ["DCJAX_TEST_CACHE_DIR"] = tempfile.mkdtemp(prefix="dcjax-test-xla-")
os.environ["DCJAX_CACHE_DIR"] = os.environ["DCJAX_TEST_CACHE_DIR"]
os.environ.pop("DCJAX_NO_CACHE", None)

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
    dcjax.use_compilation_cache(min_compile_seconds=0.2)


# The modules whose tests take longest (15-35 s each on a 2-core Xeon: `pytest --durations=25`).
LONGEST = ("test_reproduce", "test_posterior", "test_composition", "test_prediction", "test_checks", "test_pmsm", "test_initial_noise")


def pytest_collection_modifyitems(config, items):
    """`LONGEST`'s modules first, then the others by how many `slow` tests they hold (a module's
    tests together, in their order): longest first, so that an xdist worker ends the run on short
    tests instead of starting a 30 s one while the other waits with nothing left to take."""
    slow = collections.Counter(item.module.__name__ for item in items if item.get_closest_marker("slow"))
    first = {}
    for item in items:
        first.setdefault(item.module.__name__, len(first))

    def key(item):
        name = item.module.__name__
        return (LONGEST.index(name) if name in LONGEST else len(LONGEST), -slow[name], first[name])

    items.sort(key=key)


def pytest_unconfigure(config):
    if _OWN_CACHE:
        shutil.rmtree(os.environ["DCJAX_TEST_CACHE_DIR"], ignore_errors=True)
