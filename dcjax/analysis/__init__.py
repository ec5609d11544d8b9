"""What a fit and a recording say, on arrays and problems (no search): uncertainty and
identifiability, the equation-error first estimate and automatic bounds, validation, the fit
report's text and plots, and the design of the next experiment's input."""

from .design import Design, design_input, evaluate_input
from .estimate import auto_bounds, auto_range, initial_estimate
from .uncertainty import Uncertainty, consistency, profile

__all__ = [
    "Design",
    "Uncertainty",
    "auto_bounds",
    "auto_range",
    "consistency",
    "design_input",
    "evaluate_input",
    "initial_estimate",
    "profile",
]
