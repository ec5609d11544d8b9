"""What a fit is, before anything is compiled: a `Plan` (the model, the integrator, the `Search`
and the `Observation`, resolved and checked once at the boundary, shared by every recording of
a fit or a batch) and a `Setup` per fit (its recordings, the search vector's `Parameters`, the
problems, the search space, start rows, weights and data-check findings)."""

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError
from ..io.recording import Recording
from ..models import Model
from ..models.bounds import Bounds
from ..models.parameters import Parameters
from ..models.precision import physical_precision
from ..models.space import Space, vector_space
from ..simulation.integrators import AutoSubsteps, Integrator
from ..simulation.joint import JointProblem, Layout
from ..simulation.problem import Problem
from .observation import Observation
from .parameter_spec import resolve_parameters
from .problems import channel_weights, joint_weights, problems_of
from .search import Search
from .vector import base_name, search_vector, start_rows


# -- one fit's setup -----------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Setup:
    """One fit, prepared: the recordings (one, or a joint set), the model, the resolved
    `Parameters` of the search vector and the integrator, and what the compiled runs take
    (problems, space, start rows, joint weights); the data checks' `findings`."""

    recordings: list[Recording]
    model: Model
    params: Parameters  # of the search vector (`dcjax.fitting.vector`)
    integrator: Integrator
    problems: list[Problem]
    space: Space
    starts: np.ndarray | None  # (K, D) unit cube, NaN where not given
    joint_weights: list[float]
    weights: tuple[float, ...] | None  # channel weights (None: all 1)
    observation: Observation = dataclasses.field(default_factory=Observation)
    layout: Layout | None = None  # None: the model's parameters, shared
    findings: tuple = ()  # data-check findings of the recordings (`dcjax.analysis.checks.Finding`)

    @property
    def target(self) -> JointProblem:
        """The objective over the search vector (every recording, its weight, the layout)."""
        layout = self.layout or Layout.plain(self.model.names, len(self.problems))
        return JointProblem(tuple(self.problems), tuple(float(w) for w in self.joint_weights), layout)

    def physical_precision(self) -> list[float]:
        """The memory precision of every entry of the search vector: a model parameter's (given,
        else the model's; Table 29 for the paper's), 1e-6 of the range for the observation's."""
        given = {base_name(n): p.precision for n, p in self.params.items() if p.precision is not None and base_name(n) in self.model.names}
        model_prec = dict(zip(self.model.names, physical_precision(given or None, self.model)))
        lo, hi = self.params.lower, self.params.upper
        out = []
        for k, (n, p) in enumerate(self.params.items()):
            b = base_name(n)
            out.append(float(model_prec[b]) if b in model_prec else p.precision if p.precision is not None else 1e-6 * float(hi[k] - lo[k]))
        return out

    def precision(self) -> np.ndarray:
        """The memory precisions of the free parameters in the unit cube."""
        p = np.asarray(self.physical_precision())
        if not np.all(p >= 0) or np.any(np.isnan(p)):
            raise ConfigError(f"precision needs non-negative numbers, got {p!r}")
        return self.space.free_of(p) / np.asarray(self.space.upper - self.space.lower)

    def with_integrator(self, integrator: Integrator) -> "Setup":
        """The same fit simulated with another integrator (other sub-steps)."""
        return dataclasses.replace(
            self, integrator=integrator, problems=problems_of(self.recordings, self.model, integrator, self.weights, self.observation)
        )


# -- what every recording of a fit shares --------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Plan:
    """A fit's model, integrator (or `AutoSubsteps`), `Search` and `Observation`, resolved and
    checked together once (`plan`); `setup` prepares one fit of recordings with it.
    `default_stop`: the search's stopping rule is the default's, not asked for, so a fit of the
    paper's data runs without it (`dcjax.fitting.sets.for_data`)."""

    model: Model
    integrator: Integrator | AutoSubsteps
    search: Search
    observation: Observation
    default_stop: bool = False

    def setup(self, recordings: Sequence[Recording], params, starts=None, findings=()) -> Setup:
        """The `Setup` of a fit of `recordings`: `params` resolved (`resolve_parameters`: None, a
        preset, "auto" or `Parameters`, which may hold the observation's parameters too), the
        search vector (`dcjax.fitting.vector`), its space and the problems. A fixed parameter's
        value may lie outside its range (a known value overrides it). `starts`: start rows in any
        form `start_rows` takes, instead of the parameters' values."""
        recordings, model = list(recordings), self.model
        own, given = resolve_parameters(params, recordings, model)
        local = [n for n, p in own.items() if p.local and not p.vary]
        if local and len(recordings) > 1:
            raise ConfigError(f"local: {', '.join(local)} is fixed (one known value); a local parameter must be searched")
        observation = self.observation.with_defaults(tuple(c for c in model.outputs if c in model.states), recordings, model.derivative_of)
        extras = observation.parameters(model, recordings, given)
        integrator = self.integrator.integrator if isinstance(self.integrator, AutoSubsteps) else self.integrator
        layout, vec = search_vector(model, recordings, own, extras, observation)
        fixed = vec.fixed
        lo, hi = vec.lower.copy(), vec.upper.copy()
        for k, n in enumerate(vec.names):
            if n in fixed and not (np.isfinite(lo[k]) and np.isfinite(hi[k]) and lo[k] <= fixed[n] <= hi[k]):  # a fixed one needs no range
                lo[k] = hi[k] = fixed[n]
        log = tuple(n for n, p in vec.items() if p.scale == "log")
        space = vector_space(vec.names, Bounds(lo, hi, vec.names), fixed, f"model {model.name}", log)
        weights = channel_weights(recordings, model)
        problems = problems_of(recordings, model, integrator, weights, observation)
        x0 = starts if starts is not None else (vec.start or None)
        jw = joint_weights(recordings, pooled=observation.loss.normalize == "none")
        trivial = layout.names == tuple(model.names) and layout.shared and not layout.adjusted  # Layout.plain: nothing to lay out
        return Setup(
            recordings,
            model,
            vec,
            integrator,
            problems,
            space,
            start_rows(x0, model, space),
            jw,
            weights,
            observation,
            None if trivial else layout,
            tuple(findings),
        )
