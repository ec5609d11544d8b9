"""A fit's parameters as they are usually given: a preset or `"auto"`, ranges, known values, start
values, log-scale and per-recording names (`ParameterSpec`), resolved into the `Parameters` of
every recording set it meets (`ParameterSpec.resolve`). The command line builds one from its
flags; a Python user writes the same in one object instead of editing `Parameters`."""

import dataclasses
import warnings
from collections.abc import Mapping, Sequence

import numpy as np

from ..analysis.estimate import auto_bounds
from ..errors import ConfigError
from ..io.recording import Recording
from ..models import MODELS, Model
from ..models.bounds import Bounds, resolve_bounds
from ..models.parameters import Parameter, Parameters

OBSERVED = ("y0_", "offset_", "delay_")  # the experiment's parameters (`dcjax.Observation`), not the model's


def observed(name: str) -> bool:
    """A name of the experiment's parameters: y0_*, offset_*, delay_*."""
    return name.startswith(OBSERVED)


def sidecar_preset(recordings: list[Recording], model: Model) -> str:
    """The bounds the recordings' sidecars name (`"bounds"`), where they all name the same preset
    of `model`, else "auto". A name that is no preset of any built-in model (a typo) is a
    one-line error; another model's preset, or sidecars that disagree, a warning."""
    named = {r.metadata.get("bounds") for r in recordings} - {None}
    if not named:
        return "auto"
    known = {p for cls in MODELS.values() for p in cls().preset_names} | set(model.preset_names) | {"auto"}
    bad = sorted(str(n) for n in named if str(n).lower() not in known)
    if bad:
        raise ConfigError(
            f"the sidecar's bounds {', '.join(map(repr, bad))} is no preset: model {model.name} has "
            f"{', '.join(model.preset_names) or 'none'}, or auto"
        )
    if len(named) > 1 or str(next(iter(named))).lower() not in (*model.preset_names, "auto"):
        what = "differ" if len(named) > 1 else "is no preset of model " + model.name
        warnings.warn(
            f"the sidecars' bounds {', '.join(sorted(map(str, named)))} {what}: auto bounds (params='PRESET' names one)", stacklevel=3
        )
        return "auto"
    return str(next(iter(named))).lower()


@dataclasses.dataclass(frozen=True)
class ParameterSpec:
    """The parameters of a fit, in short: `preset` (a preset of the model, `"auto"`: ranges from an
    equation-error first estimate, whose values start the search; None: the recordings' sidecar
    preset, else auto) or `lower`/`upper` (every bound in the model's order); `ranges` name ->
    (LO, HI) over them (the experiment's `y0_*`, `offset_*`, `delay_*` too); `fixed` name -> a known
    value (not searched; inside its range where a range is given); `start` name -> a start value
    (default the auto estimate's, where inside the ranges); `log` names searched on a log scale;
    `local` names with one value per recording of a joint fit; `precision` the memory's
    precisions, name -> value or one per parameter.

        dcjax.fit(recs, "dc", dcjax.ParameterSpec("table4", ranges={"Ra": (0, 10)}, fixed={"Tlc": 0.0}))"""

    preset: str | None = None
    lower: Sequence[float] | None = None
    upper: Sequence[float] | None = None
    ranges: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    fixed: Mapping[str, float] = dataclasses.field(default_factory=dict)
    start: Mapping[str, float] = dataclasses.field(default_factory=dict)
    log: tuple[str, ...] = ()
    local: tuple[str, ...] = ()
    precision: "Mapping[str, float] | Sequence[float] | None" = None

    def __post_init__(self):
        if (self.lower is None) != (self.upper is None):
            raise ConfigError("ParameterSpec: lower and upper must be given together")
        if self.lower is not None and self.preset is not None:
            raise ConfigError("ParameterSpec: give either preset or lower/upper, not both")
        for other, names in (("start", self.start), ("log", self.log), ("local", self.local)):
            both = [n for n in names if n in self.fixed]
            if both:  # a known value is not searched: a start, a scale or a value per recording would be ignored
                raise ConfigError(
                    f"ParameterSpec: fixed= and {other}= both name {', '.join(both)}: a fixed parameter is not searched; drop one"
                )
        for n, v in self.fixed.items():
            lo, hi = self.ranges.get(n, (-float("inf"), float("inf")))
            if not lo <= v <= hi:
                raise ConfigError(
                    f"ParameterSpec: fixed {n}={v:g} lies outside its range {lo:g}:{hi:g}: a known value is not searched; give one of them"
                )

    def bounds(self, model: Model, recordings: list[Recording]) -> tuple[Bounds, dict[str, float]]:
        """(the model's parameters' bounds, the auto estimate's start values) for `recordings`."""
        given = {k: v for k, v in self.ranges.items() if k in model.names or not observed(k)}
        start: dict[str, float] = {}
        if self.lower is not None and self.upper is not None:
            bounds = Bounds(list(self.lower), list(self.upper), model.names)
        else:
            preset = self.preset or sidecar_preset(recordings, model)
            known = {n: (float(v), float(v)) for n, v in self.fixed.items() if n in model.names and n not in given}
            if preset.lower() == "auto" and set(model.names) <= set(given) | set(known):  # every range given or value known
                ranges = {**known, **given}
                bounds = Bounds([ranges[n][0] for n in model.names], [ranges[n][1] for n in model.names], model.names)
            elif preset.lower() == "auto":  # the known values held in the estimate: they pin what the data may not
                bounds, start, _ = auto_bounds(recordings, model, {n: lo for n, (lo, _) in known.items()})
            else:
                bounds = resolve_bounds(model, preset)
        return resolve_bounds(model, bounds, given), start

    def resolve(self, model: Model, recordings: "Recording | list[Recording]") -> Parameters:
        """The `Parameters` of a fit of `recordings` (the ranges of `auto` estimated from every one
        of them): the model's, then the experiment's that `ranges`, `fixed`, `start` or `local` name."""
        recs = recordings if isinstance(recordings, list) else [recordings]
        unknown = [n for n in self.local if n not in model.names and not observed(n)]
        if unknown:
            raise ConfigError(
                f"local: unknown parameter {', '.join(unknown)}; model {model.name} has {', '.join(model.names)} (and the fit's offset_CH, delay_IN)"
            )
        if self.local and len(recs) < 2:
            raise ConfigError("local: needs a joint fit of several recordings (each gets its own value)")
        bounds, estimated = self.bounds(model, recs)
        fixed = {k: v for k, v in self.fixed.items() if not observed(k)}
        start = {k: v for k, v in self.start.items() if not observed(k)}
        model.check_names(fixed, "fixed parameter")
        model.check_names(start, "start value")
        model.check_names(set(self.log), "log parameter")
        lo, hi = bounds.lower, bounds.upper
        if not start:
            start = {n: v for n, v in estimated.items() if lo[model.names.index(n)] <= v <= hi[model.names.index(n)]}
        prec = self._precision(model)
        out = [
            Parameter(
                n,
                value=fixed.get(n, start.get(n)),
                min=float(lo[k]),
                max=float(hi[k]),
                vary=n not in fixed,
                unit=model.units.get(n, ""),
                precision=prec.get(n),
                local=n in self.local,
                scale="log" if n in self.log else "linear",
            )
            for k, n in enumerate(model.names)
        ]
        extra = dict.fromkeys(k for group in (self.ranges, self.fixed, self.start, self.local) for k in group if observed(k))
        for n in extra:
            lo_n, hi_n = self.ranges.get(n, (float("-inf"), float("inf")))
            value = self.fixed.get(n, self.start.get(n))
            out.append(Parameter(n, value=value, min=lo_n, max=hi_n, vary=n not in self.fixed, local=n in self.local))
        return Parameters(out)

    def _precision(self, model: Model) -> dict[str, float]:
        if self.precision is None:
            return {}
        if isinstance(self.precision, Mapping):
            given = {str(k): float(v) for k, v in self.precision.items()}
            model.check_names(given)
            return given
        values = [float(v) for v in self.precision]
        if len(values) != model.n_params:
            raise ConfigError(f"precision: {model.n_params} values (one per parameter of model {model.name}), got {len(values)}")
        return dict(zip(model.names, values))


def resolve_parameters(params, recordings: list[Recording], model: Model) -> tuple[Parameters, Parameters]:
    """(the model's `Parameters`, the observation's given ones) from `params`: None (the
    recordings' sidecar preset where they name one, else "auto"), a preset name, "auto"
    (`dcjax.analysis.estimate.auto_bounds`: ranges from an equation-error first estimate, whose
    values seed the search) or `Parameters` (copied; split by `split_parameters`)."""
    if isinstance(params, ParameterSpec):
        params = params.resolve(model, recordings)
    if params is None:
        params = sidecar_preset(recordings, model)
    if isinstance(params, str) and params.lower() == "auto":
        bounds, start, _ = auto_bounds(recordings, model)
        return parameters_of(model, bounds, start), Parameters()
    if isinstance(params, str):
        return model.parameters(params), Parameters()
    if not isinstance(params, Parameters):
        raise ConfigError(
            f"params must be None, 'auto', a preset name {sorted(model.preset_names)} or dcjax.Parameters, got {type(params).__name__}"
        )
    own, extras = split_parameters(params, model)  # copies
    own.check(model.names, model.name)
    for n, p in extras.items():
        if p.vary and p.min > p.max:
            raise ConfigError(f"parameter {n}: min {p.min:g} is above max {p.max:g}")
    return own, extras


def split_parameters(params: Parameters, model: Model) -> tuple[Parameters, Parameters]:
    """(the model's parameters, the rest: the observation's `y0_*`, `offset_*`, `delay_*`)."""
    own = [params[n] for n in params if n in model.names]
    return Parameters(own if len(own) == len(model.names) else [params[n] for n in params]), Parameters(
        [params[n] for n in params if n not in model.names]
    )


def parameters_of(model: Model, bounds: Bounds, values: Mapping[str, float] | None = None) -> Parameters:
    """The model's `Parameters` (units and precisions of its default preset) with `bounds` and start `values`."""
    base = model.parameters() if model.preset_names else None
    prec = model.memory_precision or {}
    lo, hi = np.asarray(bounds.lower), np.asarray(bounds.upper)
    out = []
    for k, n in enumerate(model.names):
        p = base[n] if base is not None else Parameter(n, unit=model.units.get(n, ""), precision=prec.get(n))
        out.append(dataclasses.replace(p, min=float(lo[k]), max=float(hi[k]), value=None if values is None else values.get(n)))
    return Parameters(out)
