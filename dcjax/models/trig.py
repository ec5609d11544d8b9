"""Float64 sine and cosine of elementwise arithmetic only, for a model's map on the CPU.

XLA:CPU computes a float64 `jnp.sin` by calling the C library's scalar `sin` for every element,
and a call inside a fused loop keeps LLVM from vectorising the whole loop: with `jnp.sin` in the
servo's map, CMA-ES's 1,200 evaluations of 476 logs searched in 1.9 s, with `sin` here 1.3-1.4 s
(2-core Xeon, `python -m experiments.bench_servo_eval --fit`). `sin` and `cos` here
are additions, multiplications and selections, which vectorise:

    k = round(x 2/pi),  r = x - k pi/2   (Cody–Waite: pi/2 in three 33-bit parts, the products
                                           exact for |k| < 2^20)
    sin r, cos r on |r| <= pi/4          (the minimax polynomials of fdlibm's `__kernel_sin`
                                           and `__kernel_cos`, Sun Microsystems 1993)
    sin x = (sin r, cos r, -sin r, -cos r)[k mod 4]   (k's two low bits: an integer's and, not a
                                                       float quadrant's floor and three compares)

Against NumPy (the C library): within 1.2e-16 absolute and, where |sin x| > 1e-3, 2 ulp, on
|x| <= 1e9 (`tests/test_trig.py`); exact at 0 (either sign gives +0); NaN where x is not
finite, as `jnp.sin`."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

TWO_OVER_PI = 6.36619772367581382433e-01
PIO2 = (1.57079632673412561417e00, 6.07710050630396597660e-11, 2.02226624871116645580e-21)  # pi/2 = sum, 33 bits each
SIN = (
    -1.66666666666666324348e-01,
    8.33333333332248946124e-03,
    -1.98412698298579493134e-04,
    2.75573137070700676789e-06,
    -2.50507602534068634195e-08,
    1.58969099521155010221e-10,
)
COS = (
    4.16666666666666019037e-02,
    -1.38888888888741095749e-03,
    2.48015872894767294178e-05,
    -2.75573143513906633035e-07,
    2.08757232129817482790e-09,
    -1.13596475577881948265e-11,
)


def _horner(z, coefficients):
    acc = coefficients[-1]
    for c in coefficients[-2::-1]:
        acc = c + z * acc
    return acc


def _reduced(x):
    """(r, k): x = r + k pi/2 with |r| <= pi/4, k as an integer (its low two bits: the quadrant)."""
    k = jnp.round(x * TWO_OVER_PI)
    r = ((x - k * PIO2[0]) - k * PIO2[1]) - k * PIO2[2]
    return r, k.astype(jnp.int64)


def _kernels(r):
    """(sin r, cos r) for |r| <= pi/4 (fdlibm's kernels with no tail)."""
    z = r * r
    s = r + (z * r) * _horner(z, SIN)
    half = 0.5 * z
    w = 1.0 - half
    c = w + (((1.0 - w) - half) + z * z * _horner(z, COS))
    return s, c


def sin(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    """The sine of `x` (radians), vectorisable on the CPU (module docstring)."""
    x = jnp.asarray(x, float)
    r, k = _reduced(x)
    s, c = _kernels(r)
    v = jnp.where((k & 1) == 1, c, s)
    return jnp.where((k & 2) == 2, -v, v)  # quadrants 2 and 3


def cos(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    """The cosine of `x` (radians), vectorisable on the CPU (module docstring)."""
    x = jnp.asarray(x, float)
    r, k = _reduced(x)
    s, c = _kernels(r)
    v = jnp.where((k & 1) == 1, s, c)
    return jnp.where(((k + 1) & 2) == 2, -v, v)  # quadrants 1 and 2


__all__ = ["cos", "sin"]
