"""From parameters to responses and the objective: the `Problem` (arrays only), Euler/RK4 with
ND sub-steps as a `lax.scan` (eq. 28-29), the Pallas kernel that holds a population's whole time
loop on a GPU, the normalized objective (eq. 24, 27) and the adaptive diffrax reference."""

from .diffrax_reference import reference_simulate, simulation_error
from .joint import stacked_residuals
from .objectives import objective, population_objective, residuals, simulate, simulate_outputs
from .problem import Problem, make_problem

__all__ = [
    "Problem",
    "make_problem",
    "objective",
    "population_objective",
    "reference_simulate",
    "residuals",
    "simulate",
    "simulate_outputs",
    "simulation_error",
    "stacked_residuals",
]
