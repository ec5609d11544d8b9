import jax
import pytest

import dcjax
from dcjax import datasets


@pytest.fixture(scope="session")
def sd1():
    return datasets.load("SD1")


@pytest.fixture(scope="session")
def sd1_true():
    return dcjax.Params.from_dict(datasets.true_params("SD1"))


def pytest_configure(config):
    assert jax.config.jax_enable_x64, "dcjax must enable float64"
