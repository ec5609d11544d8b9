"""Gradients that JAX takes in forward mode whatever mode its caller asks for, and when to.

`forward_gradient(fn)` is `fn` (R^P -> R) with a JVP rule that evaluates it with one tangent per
entry of `y` (`jax.vmap` of `jax.jvp`): its gradient, and so its transpose, is a dot product with
those P derivatives. A quasi-Newton solver (`optimistix.BFGS`) then differentiates a Kalman
filter's time loop forward, where reverse mode builds a second, transposed loop that XLA:CPU
compiles slowly inside the solver's compiled loop. On the composition matrix's prediction cell
(an EKF on a motor's sensors, two recordings of 240 samples, RK4 ND 4, 12 free parameters), the
value and gradient compile in 1.5 s against 5.1 s and evaluate in 8.6 ms against 3.4 ms; the
BFGS polish compiles in 3.9 s against 15.7 s and takes 8.5 s in all against 18.4 s, to the same
objective and 219 steps both. The gradient agrees with reverse mode to ~1e-16 relative."""

from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float


def forward_gradient(fn: Callable[[Float[Array, " P"]], Float[Array, ""]]) -> Callable[[Float[Array, " P"]], Float[Array, ""]]:
    """`fn` whose derivative JAX takes by P forward-mode tangents (the columns of the identity)."""

    @jax.custom_jvp
    def f(y):
        return fn(y)

    @f.defjvp
    def f_jvp(primals, tangents):
        (y,), (dy,) = primals, tangents
        value, grad = jax.vmap(lambda t: jax.jvp(fn, (y,), (t,)), out_axes=(None, 0))(jnp.eye(y.shape[0], dtype=y.dtype))
        return value, grad @ dy

    return f


# Forward mode's evaluation costs about (P + 1) / 5 of reverse mode's, its compilation a fraction:
# where P x the integration steps of an evaluation (of every start a program runs) is below this,
# the compile seconds saved outweigh the extra ones of a solver's ~250 steps. The paper's motor's prediction-error polish
# (`python -m experiments.bench_forward_gradient`, 11 free parameters): 500 samples 0.74 of
# reverse mode's time, 2,000 0.93, 8,000 1.19; the matrix's cell above (23,000) 0.46.
FORWARD_WORK = 4e4


def forward_mode(free: int, steps: int) -> bool:
    """Whether a solver takes the gradient of an objective of `free` parameters, whose evaluation
    integrates `steps` steps, in forward mode (`FORWARD_WORK`)."""
    return free * steps < FORWARD_WORK


__all__ = ["FORWARD_WORK", "forward_gradient", "forward_mode"]
