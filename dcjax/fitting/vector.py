"""A fit's search vector: the model's parameters (shared, or `local`: one copy per recording of a
joint fit, named `Tla[0]`, `Tla[1]`, ...), then the fitted initial states `y0_<state>` (one per
recording), the sensor offsets `offset_<channel>` and the input delays `delay_<input>` (shared
unless local). Each entry is a `Parameter` with its range; the `Layout` says which columns each
recording takes.

Automatic ranges: an offset +-10 % of the channel's peak over the fit's recordings, a delay 0..10
samples (in seconds, the median sample interval), a fitted initial state the measured channel's
range widened by 10 % of its peak (or +-1.5x the largest filtered derivative for a derivative
state; a noisy state fitted by default: its first samples +- 8 noise sd, `observation.start_range`);
a `Parameter` of that name in the fit's `params` (`--bound`) replaces it.

Also here: a fit's `params` resolved (`resolve_parameters`: a preset, "auto" or `Parameters`)
and its start values as unit-cube rows (`start_rows`)."""

import dataclasses
import re
from collections.abc import Mapping

import numpy as np

from ..analysis.estimate import auto_bounds
from ..errors import ConfigError
from ..io.recording import Recording
from ..io.units import SI_UNITS
from ..models import Model
from ..models.bounds import Bounds
from ..models.parameters import Parameter, Parameters
from ..models.space import Space
from ..simulation.joint import Layout
from .observation import Observation, derivative_at_start, start_range
from .parameter_spec import ParameterSpec, sidecar_preset

OFFSET_SHARE = 0.10
DELAY_SAMPLES = 10.0
_INDEXED = re.compile(r"^(.+)\[(\d+)\]$")


def base_name(name: str) -> str:
    """`Tla[2]` -> `Tla`; other names unchanged."""
    m = _INDEXED.match(name)
    return m.group(1) if m else name


def extra_names(model: Model, observation: Observation) -> tuple[str, ...]:
    """The names of the observation's parameters (before the per-recording copies)."""
    return (
        *(f"y0_{s}" for s in observation.fitted_states()),
        *(f"offset_{c}" for c in observation.offsets),
        *(f"delay_{u}" for u in observation.delays),
    )


def unit_of(name: str, model: Model) -> str:
    """The unit of a search-vector entry."""
    n = base_name(name)
    if n in model.names:
        return model.units.get(n, "")
    if n.startswith("delay_"):
        return "s"
    channel = n.removeprefix("y0_").removeprefix("offset_")
    return SI_UNITS.get(model.quantities.get(channel, ""), "")


def default_extra(name: str, model: Model, recordings: list[Recording], observation: Observation) -> Parameter:
    """The automatic range and start value of an observation parameter (module docstring)."""
    unit = unit_of(name, model)
    if name.startswith("offset_"):
        c = name.removeprefix("offset_")
        peak = max(float(np.max(np.abs(r[c]))) for r in recordings)
        return Parameter(name, value=0.0, min=-OFFSET_SHARE * peak, max=OFFSET_SHARE * peak, unit=unit)
    if name.startswith("delay_"):
        h = float(np.median(np.concatenate([np.diff(r.t) for r in recordings])))
        return Parameter(name, value=None, min=0.0, max=DELAY_SAMPLES * h, unit=unit)
    state = name.removeprefix("y0_")
    if observation.defaulted(state):
        lo, hi = start_range(state, recordings)
        return Parameter(name, value=None, min=lo, max=hi, unit=unit)
    if all(state in r.channels for r in recordings):
        lo = min(float(np.min(r[state])) for r in recordings)
        hi = max(float(np.max(r[state])) for r in recordings)
        pad = OFFSET_SHARE * max(abs(lo), abs(hi), 1e-12)
        return Parameter(name, value=None, min=lo - pad, max=hi + pad, unit=unit)
    src = model.derivative_of.get(state)
    if src is not None and all(src in r.channels for r in recordings):
        top = max(float(np.max(np.abs(np.gradient(np.asarray(r[src], float), r.t)))) for r in recordings)
        top = max(top, abs(max(derivative_at_start(r, src, state) for r in recordings)), 1e-12)
        return Parameter(name, value=None, min=-1.5 * top, max=1.5 * top, unit=unit)
    raise ConfigError(
        f"initial: {state}=fit needs a range: state {state} is not measured; give it, e.g. params[{name!r}].set(min=LO, max=HI)"
    )


def search_vector(model: Model, recordings: list[Recording], params: Parameters, extras: Parameters, observation: Observation):
    """(Layout, Parameters of the search vector) of a fit: `params` the model's (each may be
    `local`), `extras` the observation parameters given (ranges, start values, `local`), the rest
    automatic."""
    n_rec = len(recordings)
    known = set(extra_names(model, observation))
    bad = [n for n in extras if n not in known]
    if bad:
        hint = ", ".join(sorted(known)) or "none (no initial={STATE: 'fit'}, offsets= or delays=)"
        raise ConfigError(f"unknown parameter(s) {', '.join(bad)} for model {model.name}; beyond its own the fit has {hint}")
    entries: list[Parameter] = []
    cols: dict[str, list[int]] = {}  # base name -> column per recording

    def add(p: Parameter, local: bool) -> None:
        if local and n_rec > 1 and p.vary:
            cols[p.name] = []
            for r in range(n_rec):
                cols[p.name].append(len(entries))
                entries.append(dataclasses.replace(p, name=f"{p.name}[{r}]", local=True))
        else:
            cols[p.name] = [len(entries)] * n_rec
            entries.append(dataclasses.replace(p, local=bool(local and n_rec > 1 and p.vary)))

    for n in model.names:
        add(params[n], params[n].local)
    for n in extra_names(model, observation):
        p = extras[n] if n in extras else default_extra(n, model, recordings, observation)
        if n in extras and not (np.isfinite(p.min) and np.isfinite(p.max)):
            auto = default_extra(n, model, recordings, observation)
            p = dataclasses.replace(p, min=auto.min if not np.isfinite(p.min) else p.min, max=auto.max if not np.isfinite(p.max) else p.max)
        add(p, p.local or n.startswith("y0_"))
    layout = Layout(
        names=tuple(p.name for p in entries),
        model_cols=tuple(tuple(cols[n][r] for n in model.names) for r in range(n_rec)),
        y0_states=tuple(model.states.index(s) for s in observation.fitted_states()),
        y0_cols=tuple(tuple(cols[f"y0_{s}"][r] for s in observation.fitted_states()) for r in range(n_rec))
        if observation.fitted_states()
        else (),
        offset_channels=tuple(model.outputs.index(c) for c in observation.offsets),
        offset_cols=tuple(tuple(cols[f"offset_{c}"][r] for c in observation.offsets) for r in range(n_rec)) if observation.offsets else (),
        delay_inputs=tuple(model.inputs.index(u) for u in observation.delays),
        delay_cols=tuple(tuple(cols[f"delay_{u}"][r] for u in observation.delays) for r in range(n_rec)) if observation.delays else (),
        measured_start=measured_start(observation),
    )
    return layout, Parameters(entries)


def measured_start(observation: Observation) -> tuple[int, ...]:
    """The offset channels whose state starts at its measured first sample (less the offset)."""
    return tuple(j for j, c in enumerate(observation.offsets) if observation.initial.get(c, "measured") == "measured")


def layout_of(names: tuple[str, ...], model: Model, observation: Observation, n_rec: int) -> Layout:
    """The layout a saved result's vector `names` imply (`load_result`)."""
    index = {n: k for k, n in enumerate(names)}

    def col(base: str, r: int) -> int:
        return index[f"{base}[{r}]"] if f"{base}[{r}]" in index else index[base]

    fitted = observation.fitted_states()
    return Layout(
        names=tuple(names),
        model_cols=tuple(tuple(col(n, r) for n in model.names) for r in range(n_rec)),
        y0_states=tuple(model.states.index(s) for s in fitted),
        y0_cols=tuple(tuple(col(f"y0_{s}", r) for s in fitted) for r in range(n_rec)) if fitted else (),
        offset_channels=tuple(model.outputs.index(c) for c in observation.offsets),
        offset_cols=tuple(tuple(col(f"offset_{c}", r) for c in observation.offsets) for r in range(n_rec)) if observation.offsets else (),
        delay_inputs=tuple(model.inputs.index(u) for u in observation.delays),
        delay_cols=tuple(tuple(col(f"delay_{u}", r) for u in observation.delays) for r in range(n_rec)) if observation.delays else (),
        measured_start=measured_start(observation),
    )


def transferred(layout: Layout, n_rec: int) -> Layout:
    """The layout for `n_rec` recordings the fit did not see: the first recording's columns (its
    local values), the offsets and delays, no fitted initial state (each starts as its spec's
    default, `Observation.initial_values`)."""
    return Layout(
        names=layout.names,
        model_cols=(layout.model_cols[0],) * n_rec,
        offset_channels=layout.offset_channels,
        offset_cols=(layout.offset_cols[0],) * n_rec if layout.offset_channels else (),
        delay_inputs=layout.delay_inputs,
        delay_cols=(layout.delay_cols[0],) * n_rec if layout.delay_inputs else (),
        measured_start=layout.measured_start,
    )


def rows_of(layout: Layout, rows: list[int]) -> Layout:
    """The layout of the fitted recordings `rows` (each with its own columns)."""
    pick = lambda cols: tuple(cols[r] for r in rows) if cols else ()
    return dataclasses.replace(
        layout,
        model_cols=pick(layout.model_cols),
        y0_cols=pick(layout.y0_cols),
        offset_cols=pick(layout.offset_cols),
        delay_cols=pick(layout.delay_cols),
    )


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


def start_rows(x0, model: Model, space: Space) -> np.ndarray | None:
    """Start values as unit-cube rows (K, D) of the free parameters, NaN where not given. `x0`:
    a name -> value mapping, a list of them, or full vectors (K, P) of the search vector
    (`space.names`). A model parameter's value seeds every local copy of it."""
    if x0 is None:
        return None
    names = space.names
    rows = x0 if isinstance(x0, (list, tuple)) and x0 and isinstance(x0[0], dict) else [x0] if isinstance(x0, dict) else None
    if rows is None:
        full = np.atleast_2d(np.asarray(x0, dtype=np.float64))
        if full.shape[-1] != len(names):
            raise ConfigError(f"x0 must be name -> value mappings or vectors of {len(names)} values {names}")
        rows = [dict(zip(names, r)) for r in full]
    lo, hi = np.asarray(space.lower), np.asarray(space.upper)
    out = np.full((len(rows), space.dim), np.nan)
    for i, row in enumerate(rows):
        bad = [n for n in row if n not in names and n not in model.names]
        if bad:
            raise ConfigError(f"unknown start value {', '.join(map(repr, bad))}; the fit's parameters are {', '.join(names)}")
        row = {
            **{c: v for n, v in row.items() if n not in names for c in names if base_name(c) == n},
            **{n: v for n, v in row.items() if n in names},
        }
        for n, v in row.items():
            if n in space.fixed:
                continue
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ConfigError(f"start value of {n} must be a number, got {v!r}") from None
            j = space.free_names.index(n)
            if not lo[j] <= v <= hi[j]:
                raise ConfigError(f"start value {n}={v:g} lies outside its bounds [{lo[j]:g}, {hi[j]:g}]")
            out[i, j] = (v - lo[j]) / (hi[j] - lo[j])
    return out
