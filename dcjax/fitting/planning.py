"""The options of `fit` and `fit_each` made one `Plan` at the boundary (`plan`): the model
resolved, the search resolved (`search_of`), the integrator and the observation checked against
the model and each other, with one-line errors, before any recording is read."""

from collections.abc import Mapping

from ..errors import ConfigError
from ..models import get_model
from ..models.base import DiscreteModel
from ..simulation.integrators import AutoSubsteps, Integrator, integrator_for
from .observation import Observation
from .search import Search, search_of
from .setup import Plan


def plan(
    model=None,
    search: "Search | Mapping | None" = None,
    *,
    observation: Observation | None = None,
    integrator: Integrator | AutoSubsteps | None = None,
    default: Search | None = None,
    legacy: Mapping | None = None,
) -> Plan:
    """The `Plan` of `fit`'s and `fit_each`'s options, every one checked against the others
    (one-line errors); the search resolved by `search_of` (None: `default`, else `Search.own()`);
    a stopping rule not asked for is the default's (`Plan.default_stop`: none for the paper's data)."""
    if observation is None:
        observation = Observation()
    if not isinstance(observation, Observation):
        raise ConfigError(f"observation must be a dcjax.Observation(loss=, initial=, offsets=, delays=, measure=), got {observation!r}")
    default_stop = search is None or (isinstance(search, Mapping) and "stop" not in search)
    search = search_of(search, dict(legacy or {}), Search.own() if default is None else default)
    resolved = get_model(model)
    m = observation.check(resolved).observed(resolved)
    if search.polish and not observation.loss.least_squares:
        raise ConfigError(
            f"polish: Levenberg-Marquardt needs a least-squares loss (sse or huber); the {observation.loss.spec} loss has none"
        )
    if isinstance(m, DiscreteModel):
        if isinstance(integrator, AutoSubsteps):
            raise ConfigError(f"model {m.name} is a discrete-time model: AutoSubsteps (sub-steps) does not apply")
        return Plan(m, integrator_for(m, integrator), search, observation, default_stop)
    if integrator is not None and not isinstance(integrator, (Integrator, AutoSubsteps)):
        raise ConfigError(
            f"integrator must be dcjax.Euler(...), dcjax.RK4(...), a dcjax.Integrator of your own or dcjax.AutoSubsteps(...), got {integrator!r}"
        )
    return Plan(
        m, integrator_for(m, integrator) if not isinstance(integrator, AutoSubsteps) else integrator, search, observation, default_stop
    )
