"""A fit's search vector: the model's parameters (shared, or `local`: one copy per recording of a
joint fit, named `Tla[0]`, `Tla[1]`, ...), then the fitted initial states `y0_<state>` (one per
recording), the sensor offsets `offset_<channel>`, the input delays `delay_<input>` and a state
estimator's noise, `q_<state>` and `r_<output>` (shared unless local). Each entry is a `Parameter` with its range; the `Layout` says which columns each
recording takes.

The experiment's entries and their automatic ranges are the observation's
(`Observation.parameters`); the model's come resolved (`dcjax.fitting.parameter_spec.resolve_parameters`).
Also here: the start values as unit-cube rows (`start_rows`)."""

import dataclasses
import re
from collections.abc import Sequence

import numpy as np

from ..errors import ConfigError
from ..io.recording import Recording
from ..models import Model
from ..models.parameters import Parameter, Parameters
from ..models.space import Space
from ..simulation.joint import Layout
from .observation import FROM_SAMPLES, Observation, parameter_unit

_INDEXED = re.compile(r"^(.+)\[(\d+)\]$")


def base_name(name: str) -> str:
    """`Tla[2]` -> `Tla`; other names unchanged."""
    m = _INDEXED.match(name)
    return m.group(1) if m else name


def unit_of(name: str, model: Model) -> str:
    """The unit of a search-vector entry."""
    n = base_name(name)
    return model.units.get(n, "") if n in model.names else parameter_unit(n, model)


def search_vector(model: Model, recordings: list[Recording], params: Parameters, extras: Sequence[Parameter], observation: Observation):
    """(Layout, Parameters of the search vector) of a fit: `params` the model's (each may be
    `local`), then `extras` the experiment's (`Observation.parameters`: one per recording for
    a fitted initial state, else shared unless `local`)."""
    n_rec = len(recordings)
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
    for p in extras:
        add(p, p.local or p.name.startswith("y0_"))
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
        measured_start=measured_start(observation, model),
        **_noise_columns(observation, model, lambda name, r: cols[name][r], n_rec),
    )
    return layout, Parameters(entries)


def _noise_columns(observation: Observation, model: Model, col, n_rec: int) -> dict:
    """The `Layout` fields of a state estimator's fitted noise (`Observation.fitted_noise`)."""
    states, outputs = observation.fitted_noise(model)
    return {
        "process_states": tuple(model.states.index(s) for s in states),
        "process_cols": tuple(tuple(col(f"q_{s}", r) for s in states) for r in range(n_rec)) if states else (),
        "noise_channels": tuple(model.outputs.index(c) for c in outputs),
        "noise_cols": tuple(tuple(col(f"r_{c}", r) for c in outputs) for r in range(n_rec)) if outputs else (),
    }


def measured_start(observation: Observation, model: Model) -> tuple[int, ...]:
    """The offset channels whose state starts at its measured (or smoothed) first sample (less the offset); a
    model with an output equation has none (its outputs are not its states)."""
    if model.has_output_equation:
        return ()
    return tuple(j for j, c in enumerate(observation.offsets) if observation.initial.get(c, "measured") in FROM_SAMPLES)


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
        measured_start=measured_start(observation, model),
        **_noise_columns(observation, model, col, n_rec),
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
        process_states=layout.process_states,
        process_cols=(layout.process_cols[0],) * n_rec if layout.process_states else (),
        noise_channels=layout.noise_channels,
        noise_cols=(layout.noise_cols[0],) * n_rec if layout.noise_channels else (),
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
        process_cols=pick(layout.process_cols),
        noise_cols=pick(layout.noise_cols),
    )


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
