"""`dcjax.models.trig`'s vectorisable float64 sine and cosine against NumPy's (the C library's):
within 2 ulp where the value is not tiny and 1.2e-16 absolute everywhere on |x| <= 1e9, exact at
0, NaN where not finite, and a fused loop that holds them compiles without a call (the reason they
exist)."""

import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dcjax.models.trig import cos, sin


@pytest.mark.parametrize("ours, numpy", [(sin, np.sin), (cos, np.cos)])
@pytest.mark.parametrize("limit", [1.0, 100.0, 1e5, 1e9])
def test_within_two_ulp_of_numpy(ours, numpy, limit):
    rng = np.random.default_rng(int(limit))
    x = np.concatenate([rng.uniform(-limit, limit, 200_000), np.arange(-64, 65) * (np.pi / 4)])
    got, want = np.asarray(jax.jit(ours)(x)), numpy(x)
    err = np.abs(got - want)
    assert err.max() <= 1.2e-16
    big = np.abs(want) > 1e-3
    assert np.max(err[big] / np.spacing(np.abs(want[big]))) <= 2.0


def test_special_values():
    x = jnp.array([0.0, -0.0, np.nan, np.inf, -np.inf])
    s, c = np.asarray(sin(x)), np.asarray(cos(x))
    assert s[0] == 0.0 and s[1] == 0.0 and c[0] == 1.0 and c[1] == 1.0
    assert np.all(np.isnan(s[2:])) and np.all(np.isnan(c[2:]))
    assert sin(jnp.float64(1.0)).dtype == jnp.float64


def test_a_fused_loop_with_them_calls_no_library_sine():
    """XLA:CPU lowers `jnp.sin` to a call of the C library's `sin`; ours to arithmetic."""
    x = jnp.linspace(-3.0, 3.0, 64)

    def opcodes(fn):
        text = jax.jit(fn).lower(x).compile().as_text()
        assert text is not None
        return set(re.findall(r"\]\S* (\w+)\(", text))

    theirs, ours = opcodes(lambda x: 2.0 * jnp.sin(x) + jnp.cos(x)), opcodes(lambda x: 2.0 * sin(x) + cos(x))
    assert {"sine", "cosine"} <= theirs and not {"sine", "cosine"} & ours and "multiply" in ours
