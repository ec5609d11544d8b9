"""Small matrices written out: a matrix is a tuple of rows, each a tuple of arrays that carry a
population's leading axes, so that a filter's covariance algebra over a population is a few dozen
element-wise operations XLA vectorises (batched LAPACK calls, one per member and sample, made
the first EKF 190x slower than the simulation it filters). Sizes are a model's states and
outputs: a handful."""

from collections.abc import Sequence

import jax
import jax.numpy as jnp
from jaxtyping import Array

Entry = Array | float  # a Python float: a known entry (a selection's 0 and 1, the identity's)
Vector = tuple[Entry, ...]
Matrix = tuple[Vector, ...]


def matmul(a: Matrix, b: Matrix) -> Matrix:
    """a b."""
    inner, cols = len(b), len(b[0])
    return tuple(tuple(_sum(mul(row[k], b[k][j]) for k in range(inner)) for j in range(cols)) for row in a)


def matmul_t(a: Matrix, b: Matrix) -> Matrix:
    """a b'."""
    return tuple(tuple(_sum(mul(x, y) for x, y in zip(row, other)) for other in b) for row in a)


def mul(a, b):
    """a b, where a Python 0 or 1 (a known entry: a selection, the identity) costs nothing."""
    for x, y in ((a, b), (b, a)):
        if isinstance(x, float | int):
            if x == 0:
                return 0.0
            if x == 1:
                return y
    return a * b


def sub(a, b):
    """a - b, nothing to do where b is a Python 0."""
    return a if isinstance(b, float | int) and b == 0 else a - b


def add(a: Matrix, b: Matrix) -> Matrix:
    return tuple(tuple(_sum((x, y)) for x, y in zip(ra, rb)) for ra, rb in zip(a, b))


def add_diagonal(a: Matrix, d: Sequence) -> Matrix:
    """a + diag(d)."""
    return tuple(tuple(_sum((x, d[i])) if i == j else x for j, x in enumerate(row)) for i, row in enumerate(a))


def symmetric(a: Matrix) -> Matrix:
    """The upper triangle of a mirrored below: a covariance exactly symmetric, and the lower
    entries never computed (XLA drops them; averaging a and a' took half a filter's time)."""
    n = len(a)
    return tuple(tuple(a[i][j] if i <= j else a[j][i] for j in range(n)) for i in range(n))


class Cholesky(tuple):
    """The lower factor L of a = L L' (rows), with the reciprocals of its diagonal (`inverse`)."""

    inverse: tuple


def cholesky(a: Matrix) -> Cholesky:
    """The lower factor L of a = L L' (a symmetric positive definite; NaN where it is not), the
    reciprocal of each diagonal entry computed once."""
    n = len(a)
    low: list[list] = [[0.0] * n for _ in range(n)]
    inv: list = [0.0] * n
    for j in range(n):
        d = sub(a[j][j], _sum(mul(low[j][k], low[j][k]) for k in range(j)))
        inv[j] = jax.lax.rsqrt(d)
        low[j][j] = d * inv[j]
        for i in range(j + 1, n):
            low[i][j] = sub(a[i][j], _sum(mul(low[i][k], low[j][k]) for k in range(j))) * inv[j]
    out = Cholesky(tuple(r) for r in low)
    out.inverse = tuple(inv)
    return out


def solve_lower(low: Cholesky, b: Vector) -> Vector:
    """x with L x = b (forward substitution)."""
    x: list = []
    for i in range(len(b)):
        x.append(sub(b[i], _sum(mul(low[i][k], x[k]) for k in range(i))) * low.inverse[i])
    return tuple(x)


def solve_upper_t(low: Cholesky, b: Vector) -> Vector:
    """x with L' x = b (back substitution on the lower factor)."""
    n = len(b)
    x: list = [0.0] * n
    for i in reversed(range(n)):
        x[i] = sub(b[i], _sum(mul(low[k][i], x[k]) for k in range(i + 1, n))) * low.inverse[i]
    return tuple(x)


def stacked(a: Matrix) -> Array:
    """Rows of arrays as one (..., n, m) array."""
    return jnp.stack([jnp.stack(row, axis=-1) for row in a], axis=-2)


def _sum(terms):
    """The sum, Python zeros skipped (0.0 where every term is one)."""
    out = None
    for t in terms:
        if isinstance(t, float | int) and t == 0:
            continue
        out = t if out is None else out + t
    return 0.0 if out is None else out


__all__ = [
    "Cholesky",
    "Matrix",
    "Vector",
    "add",
    "add_diagonal",
    "cholesky",
    "matmul",
    "matmul_t",
    "mul",
    "solve_lower",
    "solve_upper_t",
    "stacked",
    "symmetric",
]
