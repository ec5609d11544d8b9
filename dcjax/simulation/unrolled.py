"""Small matrices written out: a matrix is a tuple of rows, each a tuple of arrays that carry a
population's leading axes, so that a filter's covariance algebra over a population is a few dozen
element-wise operations XLA vectorises (batched LAPACK calls, one per member and sample, made
the first EKF 190x slower than the simulation it filters). Sizes are a model's states and
outputs: a handful."""

from collections.abc import Sequence
from typing import NamedTuple

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


def upper(a: Matrix) -> Vector:
    """The upper triangle of symmetric `a`, row by row: what a loop carries of a covariance
    (each entry once)."""
    n = len(a)
    return tuple(a[i][j] for i in range(n) for j in range(i, n))


def from_upper(v: Vector, n: int) -> Matrix:
    """The symmetric n x n matrix of its `upper` triangle."""
    at = {}
    k = 0
    for i in range(n):
        for j in range(i, n):
            at[i, j] = at[j, i] = v[k]
            k += 1
    return tuple(tuple(at[i, j] for j in range(n)) for i in range(n))


class LDL(NamedTuple):
    """a = L D L' with L unit lower triangular (rows; its diagonal the Python 1.0) and D diagonal:
    the square-root-free Cholesky factorisation (Golub & Van Loan, Alg. 4.1.2), with the
    reciprocals of D computed once. A filter's update needs no square root: S^-1 b and
    nu' S^-1 nu by substitution, log det S = log prod d_j."""

    lower: tuple
    d: tuple
    inverse: tuple  # 1 / d_j


def ldl(a: Matrix) -> LDL:
    """The `LDL` factors of symmetric `a` (only its lower triangle read). A d_j <= 0 means `a` is
    not positive definite: the caller checks `positive`."""
    n = len(a)
    low: list[list] = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    d: list = [0.0] * n
    inv: list = [0.0] * n
    for j in range(n):
        d[j] = sub(a[j][j], _sum(mul(mul(low[j][k], low[j][k]), d[k]) for k in range(j)))
        inv[j] = 1.0 / d[j]
        for i in range(j + 1, n):
            low[i][j] = sub(a[i][j], _sum(mul(mul(low[i][k], low[j][k]), d[k]) for k in range(j))) * inv[j]
    return LDL(tuple(tuple(r) for r in low), tuple(d), tuple(inv))


def positive(f: LDL):
    """Whether every d_j > 0 (the factored matrix positive definite)."""
    out = f.d[0] > 0
    for dj in f.d[1:]:
        out = out & (dj > 0)
    return out


def solve_unit_lower(f: LDL, b: Vector) -> Vector:
    """y with L y = b (forward substitution, unit diagonal)."""
    y: list = []
    for i in range(len(b)):
        y.append(sub(b[i], _sum(mul(f.lower[i][k], y[k]) for k in range(i))))
    return tuple(y)


def solve(f: LDL, b: Vector) -> Vector:
    """x with L D L' x = b."""
    y = solve_unit_lower(f, b)
    n = len(b)
    x: list = [0.0] * n
    for i in reversed(range(n)):
        x[i] = sub(mul(y[i], f.inverse[i]), _sum(mul(f.lower[k][i], x[k]) for k in range(i + 1, n)))
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
    "LDL",
    "Matrix",
    "Vector",
    "add",
    "add_diagonal",
    "from_upper",
    "ldl",
    "matmul",
    "matmul_t",
    "mul",
    "positive",
    "solve",
    "solve_unit_lower",
    "stacked",
    "symmetric",
    "upper",
]
