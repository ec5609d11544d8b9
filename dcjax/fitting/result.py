"""The result of an identification: best parameters, per-run results and their statistics
(paper Section 3.1, Tables 5–6: best B, worst W, mean M and standard deviation SD over runs),
its JSON form and its restoration without refitting."""

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..analysis.checks import result_findings
from ..analysis.plotting import plot_result
from ..analysis.report import fit_html, fit_report
from ..compiling import on_device
from ..errors import ConfigError
from ..io.files import strict_json, write_text
from ..io.recording import Recording, as_recording
from ..models import Model, get_model
from ..models.bounds import Bounds
from ..models.parameters import Parameter, Parameters
from ..models.priors import prior_from_spec
from ..models.space import Space, vector_space
from ..simulation.integrators import Integrator
from ..simulation.joint import JointProblem, Layout
from ..simulation.losses import get_loss
from ..simulation.problem import make_problem
from .observation import Observation
from .result_file import relative_to, result_record, settings_record
from .search import RunStatus, SearchRecord
from .simulated import outputs_on_grid, simulate_on_grid, simulated_recording
from .vector import base_name, rows_of, transferred, unit_of

if TYPE_CHECKING:
    from ..analysis.posterior import Posterior  # lazy: blackjax adds ~0.3 s to importing dcjax
    from ..analysis.uncertainty import Uncertainty  # lazy: optimistix and scipy.stats for an analysis asked for


@dataclasses.dataclass(frozen=True)
class FailedFit:
    """A recording that could not be loaded, validated or fitted, with its one-line error."""

    name: str
    error: str
    source: str | None = None
    success: bool = False
    checks: list = dataclasses.field(default_factory=list)  # data-check findings (`dcjax.analysis.checks.Finding`)


@dataclasses.dataclass(frozen=True)
class FitResult:
    """Best parameters over all runs (`params`, a `Parameters`; `best_values`, name -> float),
    per-run results and their statistics. Made once from a fit's setup and runs (or a saved
    result.json) and not changed after: `uncertainty()` returns a new result. Every field is
    typed: the model, the `search` it ran (`SearchRecord`), the integrator, the observation, the
    layout of the search vector, its bounds, the channel and joint weights, the data's sources;
    `settings` is derived from them as result.json records it."""

    best_values: dict[str, float]
    of: float
    run_of: np.ndarray  # (R,)
    run_params: np.ndarray  # (R, P), physical units, the search vector's order
    fes: np.ndarray  # (R,) real evaluations
    iterations: np.ndarray  # (R,)
    history: np.ndarray  # (R, T) best OF after each iteration (NaN past a run's end)
    search: SearchRecord
    integrator: Integrator = dataclasses.field(repr=False)
    bounds: Bounds = dataclasses.field(repr=False)  # of the search vector
    timing: dict = dataclasses.field(default_factory=dict)
    polish: dict | None = None
    dups: np.ndarray | None = None  # (R,) candidates answered from memory
    converged: np.ndarray | None = None  # (R,) whether each run ended by the search's stopping rule (`Search.stop`)
    memory_chunks: np.ndarray | None = None  # (R,) memory chunks searched
    recordings: list[Recording] = dataclasses.field(default_factory=list, repr=False)
    model: Model = dataclasses.field(default_factory=get_model, repr=False)
    fixed: dict[str, float] = dataclasses.field(default_factory=dict)
    checks: tuple = ()  # data-check findings (`dcjax.analysis.checks.Finding`)
    observation: Observation = dataclasses.field(default_factory=Observation, repr=False)  # loss, initial states, offsets, delays
    layout: Layout | None = dataclasses.field(default=None, repr=False)  # None: the model's parameters, shared
    weights: tuple[float, ...] = ()  # channel weights (eq. 27; empty: all 1)
    joint_weights: tuple[float, ...] | None = None  # each recording's share where not equal (None: equal shares)
    sources: tuple[dict | str, ...] = ()  # where each recording came from (its file, sha256, reading; or its name)
    recording_names: tuple[str, ...] = ()
    start: dict[str, float] | None = None  # the start values given (x0)
    priors: dict[str, str] = dataclasses.field(default_factory=dict)  # name -> prior spec of the parameters' own priors
    local: tuple[str, ...] = ()  # parameters with one value per recording
    log: tuple[str, ...] = ()  # entries of the search vector searched on a log scale
    precision: tuple[float, ...] | None = None  # the memory's precisions (physical), with memory
    data_points: int | None = None  # residuals: samples times compared channels
    nd_auto: dict | None = None  # the automatic sub-step choice (`AutoSubsteps`), where made
    limit_setting: float | None = None  # a 0.1 result's current limit (a setting then)
    uncertainties: "Uncertainty | None" = dataclasses.field(default=None, repr=False)  # `uncertainty()`'s analysis

    def __post_init__(self):
        object.__setattr__(self, "checks", tuple(self.checks))
        if not self.weights:
            object.__setattr__(self, "weights", (1.0,) * len(self.model.outputs))

    @property
    def settings(self) -> dict:
        """The configuration as result.json records it ("settings"), derived from the typed fields."""
        return settings_record(self)

    @property
    def names(self) -> tuple[str, ...]:
        """The search vector's names: the model's parameters (a local one as `Tla[0]`, `Tla[1]`,
        ... per recording), then `y0_<state>`, `offset_<channel>`, `delay_<input>` where fitted."""
        return self.layout.names if self.layout is not None else self.model.names

    def values(self, recording: int = 0) -> dict[str, float]:
        """The model's parameters of fitted recording `recording` (its own local values)."""
        if self.layout is None:
            return {n: self.best_values[n] for n in self.model.names}
        cols = self.layout.model_cols[recording]
        return {n: self.best_values[self.names[c]] for n, c in zip(self.model.names, cols)}

    @property
    def recording(self) -> Recording | None:
        """The (first) fitted recording."""
        return self.recordings[0] if self.recordings else None

    @property
    def space(self) -> Space:
        assert self.bounds is not None  # set in __post_init__
        return vector_space(self.names, self.bounds, self.fixed, f"model {self.model.name}", self.log)

    def integrator_used(self) -> Integrator:
        """The fitted integrator."""
        assert self.integrator is not None
        return self.integrator

    def _rows(self, recordings) -> list[int] | None:
        """The fitted recording each of `recordings` is (the object, or one of the same name and
        length), or None where one is not."""
        if recordings is None:
            return list(range(len(self.recordings)))
        rows = []
        for rec in recordings:
            k = next((k for k, r in enumerate(self.recordings) if r is rec), None)
            if k is None:
                k = next((k for k, r in enumerate(self.recordings) if r.name == rec.name and len(r) == len(rec)), None)
            if k is None:
                return None
            rows.append(k)
        return rows

    def _fitted(self, recordings) -> bool:
        return self._rows(recordings) is not None

    def problems(self, recordings=None, loss=None, measured: bool = True):
        """The settings' problems (integrator, weights, loss, initial states) for `recordings`
        (default: the fitted ones, each with its own limit); `loss` instead of the fit's;
        `measured=False`: recordings may hold the inputs alone (`make_problem`)."""
        recs = self.recordings if recordings is None else recordings
        if not recs:
            raise ConfigError("no recording: the result was loaded without its data; pass a recording")
        if self.limit_setting is not None:  # a 0.1 result file: the limit was a setting
            recs = [r.replace(limit=self.limit_setting) for r in recs]
        obs, fitted = self.observation, self._fitted(recordings)
        return [
            make_problem(
                r,
                self.integrator,
                self.weights,
                model=self.model,
                loss=obs.loss if loss is None else loss,
                initial=obs.initial_values(self.model, r, fitted),
                hold=dict(obs.hold),
                measured=measured,
                predictor=obs.predictor(self.model, r),
            )
            for r in recs
        ]

    def target(self, recordings=None, loss=None, measured: bool = True) -> JointProblem:
        """The objective over the search vector for `recordings` (default the fitted ones, with
        the fit's joint weights; others: the first recording's local values, offsets and delays,
        the initial states as their specs say, equal shares; `measured=False`: they may hold the
        inputs alone)."""
        probs = self.problems(recordings, loss, measured)
        layout = self.layout or Layout.plain(self.model.names, len(self.recordings) or 1)
        rows = self._rows(recordings)
        if rows is None:
            moved = transferred(layout, len(probs))
            outs = self.model.outputs  # a start less its offset where every recording holds the channel
            start = tuple(j for j in moved.measured_start if all(outs[moved.offset_channels[j]] in r.channels for r in recordings or []))
            return JointProblem(tuple(probs), (1.0 / len(probs),) * len(probs), dataclasses.replace(moved, measured_start=start))
        if recordings is None:  # the fit's own weights (settings: given or pooled; else equal shares)
            jw = self.joint_weights or [1.0 / len(probs)] * len(probs)
        else:
            jw = [1.0 / len(probs)] * len(probs)
        return JointProblem(tuple(probs), tuple(float(w) for w in jw), rows_of(layout, rows))

    def uncertainty(self, profile: str | None = None, profile_points: int = 11) -> "FitResult":
        """A new result with standard errors, 95 % intervals, correlations and identifiability
        verdicts at the best parameters (`dcjax.analysis.uncertainty`; in `.uncertainties`, and as each
        parameter's `stderr` in `.params`); fixed parameters are known. With `profile="Tla"`
        also a profile likelihood over the 95 % interval of that parameter
        (`.uncertainties.profile = (values, OFs)`). This result is not changed."""
        from ..analysis.uncertainty import profile as profile_fn  # lazy: optimistix and scipy.stats for an analysis asked for
        from ..analysis.uncertainty import uncertainty  # lazy: optimistix and scipy.stats for an analysis asked for

        space = self.space
        x = np.array([self.best_values[n] for n in self.names])
        loss = self.observation.loss
        sse = get_loss("sse", loss.normalize)
        own = self.target()
        squared = own if loss == sse else self.target(loss=sse)  # its J finds the null directions
        u = uncertainty(x, squared, space, robust=None if loss == sse else own)  # another loss: its sandwich
        target = own if loss.least_squares else squared  # the profile's OF
        u.approximation = self.observation.loss.approximation
        if profile is not None:
            if profile not in self.names:
                raise ConfigError(f"unknown parameter {profile!r}; the fit's parameters are {', '.join(self.names)}")
            lo, hi = u.ci95[profile]
            k = self.names.index(profile)
            b = space.bounds
            grid = np.linspace(max(lo, float(b.lower[k])), min(hi, float(b.upper[k])), profile_points)
            u.profile = (grid, profile_fn(x, profile, grid, target, space))
        return dataclasses.replace(self, uncertainties=u)

    def sample(self, draws: int = 1000, chains: int = 4, warmup: int = 1000, seed: int = 0, priors=None) -> "Posterior":
        """NUTS draws of the fitted search vector under the loss's likelihood (Gaussian for sse,
        Laplace for l1, Huber for huber; each channel's noise scale from the residuals) and the
        search space's prior (uniform in each range, log-uniform on a log scale; a parameter's own
        `Parameter(prior=...)` of the fit, or `priors`: name -> `Prior` or spec, which replace it):
        `dcjax.analysis.posterior.sample`. Needs the fitted recordings."""
        from ..analysis.posterior import sample  # lazy: blackjax adds ~0.3 s to importing dcjax

        x = np.array([self.best_values[n] for n in self.names])
        own = {n: p.prior for n, p in self.params.items() if p.prior is not None} | dict(priors or {})
        return sample(x, self.target(), self.space, self.observation.loss, draws=draws, chains=chains, warmup=warmup, seed=seed, priors=own)

    @property
    def stats(self) -> dict[str, float]:
        """B, W, M, SD of the per-run best OF (Table 5; SD is the population std, ddof = 0). A run
        with no finite OF (+inf) makes W and M +inf and SD NaN (not defined), without a warning."""
        f = self.run_of
        with np.errstate(invalid="ignore"):  # inf - inf in the std of a run with no finite OF
            return {"best": float(f.min()), "worst": float(f.max()), "mean": float(f.mean()), "std": float(f.std())}

    @property
    def duplicates(self) -> dict[str, float] | None:
        """Memory use (Tables 30–33): mean candidates answered from memory per run and that as a
        percentage of all candidates proposed, `pop_size` x (iterations + 1) (the paper's
        convention, 70 x 2000 = 140,000)."""
        if self.dups is None:
            return None
        proposed = self.search.pop_size * (self.iterations + 1)
        return {"mean": float(self.dups.mean()), "percent": float(100 * np.mean(self.dups / proposed))}

    # -- lmfit's vocabulary -------------------------------------------------------------------
    @property
    def run_status(self) -> tuple[RunStatus, ...]:
        """How each run ended: its objective not finite, its polish at its step limit, converged
        by the search's stopping rule, the strategy's iteration limit reached, or its budget spent."""
        conv = (self.polish or {}).get("converged")
        gens = self.search.generations

        def status(r: int) -> RunStatus:
            if not np.isfinite(self.run_of[r]):
                return RunStatus.NON_FINITE
            if conv is not None and not conv[r]:
                return RunStatus.POLISH_STEP_LIMIT
            if self.converged is not None and self.converged[r]:
                return RunStatus.CONVERGED
            return RunStatus.GENERATIONS if gens is not None and self.iterations[r] >= gens else RunStatus.BUDGET

        return tuple(status(r) for r in range(len(self.run_of)))

    @property
    def failure(self) -> str | None:
        """Why the fit found no parameters at all (no run's objective is finite: the model blows up
        over the whole search range), one line; None where a run found finite ones."""
        if np.any(np.isfinite(self.run_of)):
            return None
        return (
            f"no run found parameters whose simulation is finite (every OF is inf, {self.nfev:,} evaluations): the model "
            "blows up over the whole search range; check the bounds, the units and scales (units=, scale=) and the model"
        )

    @property
    def success(self) -> bool:
        """Every run ended with a finite objective and, with the polish, every polish converged
        (a polish stopped at its step limit is not a success)."""
        return bool(np.all(np.isfinite(self.run_of))) and not self._unconverged_polish()

    def _unconverged_polish(self) -> int:
        conv = (self.polish or {}).get("converged")
        return 0 if conv is None else int(len(conv) - np.sum(conv))

    @property
    def message(self) -> str:
        bad = int(np.sum(~np.isfinite(self.run_of)))
        if bad == len(self.run_of):
            return "no run found parameters whose simulation is finite"
        at = self.at_bound()
        text = f"{len(self.run_of) - bad}/{len(self.run_of)} runs finished with a finite objective"
        if bad:
            text += f" ({bad} ended non-finite)"
        stopped = self._unconverged_polish()
        if stopped:
            text += f"; the polish of {stopped} run(s) stopped at its step limit or failed"
        return text + (f"; at a bound: {', '.join(at)}" if at else "")

    @property
    def nfev(self) -> int:
        """Objective evaluations made, all runs together (memory hits not counted)."""
        return int(np.sum(self.fes))

    @property
    def ndata(self) -> int:
        """Residuals: samples times compared channels, over every recording."""
        n = self.data_points
        if n is None and self.recordings:
            n = sum(len(r) * len(self.model.outputs) for r in self.recordings)
        return int(n or 0)

    @property
    def nvarys(self) -> int:
        return len(self.names) - len(self.fixed)

    @property
    def chisqr(self) -> float:
        """Sum of the squared residuals of eq. 24/27: the best objective value."""
        return float(self.of)

    @property
    def redchi(self) -> float:
        return self.chisqr / max(1, self.ndata - self.nvarys)

    @property
    def prediction(self) -> bool:
        """A prediction-error fit (`Observation.focus`): the OF is the innovations' -log L / N."""
        return self.observation.focus == "prediction"

    @property
    def aic(self) -> float:
        """Akaike: N ln(chisqr / N) + 2 nvarys (lmfit's definition); a prediction-error fit's
        2 (-log L) + 2 nvarys, -log L = OF x samples (one recording, or equal lengths)."""
        n = max(1, self.ndata)
        if self.prediction:
            return float(2 * self.of * n / len(self.model.outputs) + 2 * self.nvarys)
        return float(n * np.log(max(self.chisqr, 1e-300) / n) + 2 * self.nvarys)

    @property
    def bic(self) -> float:
        """Bayesian: N ln(chisqr / N) + ln(N) nvarys (prediction error: 2 (-log L) + ln(samples) nvarys)."""
        n = max(1, self.ndata)
        if self.prediction:
            m = n / len(self.model.outputs)
            return float(2 * self.of * m + np.log(m) * self.nvarys)
        return float(n * np.log(max(self.chisqr, 1e-300) / n) + np.log(n) * self.nvarys)

    @property
    def params(self) -> Parameters:
        """The best values as `Parameters` (lmfit's `result.params`): bounds, vary (False for the
        fixed ones), units, memory precisions and, after `uncertainty()`, standard errors. A
        `Parameter` stands for its value in arithmetic (`result.params["Ra"] - 42.5`); the plain
        floats are `best_values`. Built from the result on each access: a copy to change and pass
        to the next `fit`, which leaves this result as it is."""
        b = self.bounds
        assert b is not None
        u = self.uncertainties
        prec = dict(zip(self.names, self.precision)) if self.precision else self.model.memory_precision or {}
        priors = self.priors
        out = []
        for k, n in enumerate(self.names):
            se = None
            if u is not None and n not in self.fixed:
                se = float(u.se[n])  # pyright: ignore[reportAttributeAccessIssue]
                se = se if np.isfinite(se) else None  # a null direction: no standard error
            out.append(
                Parameter(
                    n,
                    value=self.best_values[n],
                    min=float(b.lower[k]),
                    max=float(b.upper[k]),
                    vary=n not in self.fixed,
                    unit=unit_of(n, self.model),
                    precision=prec.get(n),
                    stderr=se,
                    local=base_name(n) in self.local,
                    scale="log" if n in self.log else "linear",
                    prior=prior_from_spec(priors[n]) if n in priors else None,
                )
            )
        return Parameters(out)

    @property
    def mean_params(self) -> dict[str, float]:
        """Mean of each parameter over runs (Table 6)."""
        return dict(zip(self.names, map(float, self.run_params.mean(axis=0))))

    def at_bound(self, rtol: float = 1e-9) -> list[str]:
        """Free parameters that ended on a search bound."""
        b = self.bounds
        assert b is not None
        lo, hi = np.asarray(b.lower), np.asarray(b.upper)
        out = []
        for k, n in enumerate(self.names):
            if n in self.fixed:
                continue
            tol = rtol * (hi[k] - lo[k])
            if self.best_values[n] - lo[k] <= tol or hi[k] - self.best_values[n] <= tol:
                out.append(n)
        return out

    def to_dict(self) -> dict:
        """result.json's content (`dcjax.fitting.result_file.result_record`)."""
        return result_record(self)

    def to_json(self, path: str | Path | None = None, files: Mapping[str, str] | None = None) -> str:
        """result.json's text (strict JSON: a non-finite number is null; `dcjax.fitting.result_file`).
        With `path` it is written there atomically, each data file's path relative to its folder;
        `files`: the sibling files written with it, name -> sha256 (readers trust only those)."""
        d = self.to_dict()
        if path is not None:
            folder = Path(path).parent
            data = [
                dict(src, path=relative_to(src["path"], folder)) if isinstance(src, dict) and src.get("path") else src
                for src in d["settings"].get("data") or []
            ]
            d["settings"] = {**d["settings"], "data": data}
        if files:
            d["files"] = dict(files)
        text = strict_json(d)
        if path is not None:
            write_text(path, text + "\n")
        return text

    def simulate(self, recording: Recording | None = None) -> np.ndarray:
        """(N, S) states of the best parameters on `recording` (default: the first fitted one; a
        fitted recording with its own local values and initial states; another may hold the
        inputs alone), with the fitted sensor offsets added to the measured states (as the
        sensors read them; a model with an output equation: the states alone, its outputs are
        `simulate_outputs`). `simulation(recording)`: the same, labelled."""
        rec = self.recording if recording is None else as_recording(recording, self.model, measured=False)
        target = self.target([rec], measured=False)
        x = on_device([self.best_values[n] for n in self.names], np.float64)
        sim = simulate_on_grid(x, target, 0)
        adj = target.adjustments(x, 0)
        if adj is not None and adj.offset is not None and not self.model.has_output_equation:
            for j, o in enumerate(self.model.output_index):
                sim[:, o] += float(adj.offset[j])
        return sim

    def simulate_outputs(self, recording: Recording | None = None) -> np.ndarray:
        """(N, C) the compared outputs (`model.outputs`, in order) of the best parameters on
        `recording` (default: the first fitted one; another may hold the inputs alone), as the
        sensors read them: through the model's output equation, with the fitted offsets."""
        x = on_device([self.best_values[n] for n in self.names], np.float64)
        recs = None if recording is None else [as_recording(recording, self.model, measured=False)]
        return outputs_on_grid(x, self.target(recs, measured=False), 0)

    def simulation(self, recording: Recording | None = None) -> Recording:
        """The simulation of `recording` (default: the first fitted one; any other, its inputs
        alone suffice) as a `Recording` named by the model: `t`, the inputs, every state (as
        `simulate`) and every output that is not a state (as `simulate_outputs`)."""
        rec = self.recording if recording is None else as_recording(recording, self.model, measured=False)
        if rec is None:
            raise ConfigError("no recording: the result was loaded without its data; pass a recording")
        return simulated_recording(self, rec)

    def validate(self, recordings, initial: "str | dict | None" = None, skip: int = 0, predict: int | None = None) -> list:
        """The held-out figures of this fit on `recordings` (`dcjax.analysis.held_out.validate`):
        per recording and output rmse, nrmse, fit %, R^2, mae and the residual tests. `initial`:
        None ("auto": a state whose start the fit fitted is estimated on the record, the others
        as their specs say), "measured" (each state as its spec says: a recorded state's first
        sample), "fitted" (the fit's fitted initial states) or "estimate"; `skip`: samples left
        out at the start; `predict=K`: of the K-step-ahead prediction (a Kalman filter's)."""
        from ..analysis.held_out import validate  # lazy: the analysis a user asks for

        return validate(self, recordings, initial=initial, skip=skip, predict=predict)

    def _repr_html_(self) -> str:
        """A notebook's table of the fit (`dcjax.analysis.report.fit_html`)."""
        return fit_html(self)

    def to_dataframe(self):
        """The parameter table (`params.to_dataframe()`: value, stderr after `uncertainty()`,
        range, vary, unit) as a pandas DataFrame. Needs pandas (`dcjax[notebook]`)."""
        return self.params.to_dataframe()

    def plot(self, path: str | Path | None = None, **kw):
        """Measured vs simulated channels with residuals and inputs (paper Figs. 8–11) and the
        convergence; see `dcjax.analysis.plotting.plot_result`."""

        return plot_result(self, path=path, **kw)

    def report(self, posterior=None) -> str:
        """lmfit's `fit_report`, the data checks' findings with the after-fit ones of the
        recordings it holds (`result_findings`); with `posterior` (a `Posterior` of this result,
        e.g. `Posterior.load("out/posterior.npz")`) its intervals beside the linearised ones."""

        return fit_report(self, posterior=posterior, findings=result_findings(self))

    def __str__(self) -> str:
        return self.report()
