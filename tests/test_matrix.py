"""The composition matrix: every option with every other, on noise-free data from the independent
NumPy reference (`tests/reference.py`), through `dcjax.fit` and `dcjax.fit_each`.

Cells: on one recording, each feature alone ({plain, a local parameter, a sensor offset, an
input delay, a fitted initial state, an initial state from the derivative of a measured
position, the default start of that derivative (fitted: "initial-derived", the DC motor's), some states compared (`measure`) while the others' columns give their initial values,
the delayed input held between samples (`zoh`) and held and delayed (`zoh-delay`)}); on two recordings of equal length (stacked), close lengths (padded into one scan) and
far lengths (one scan each, as a long search keeps them; "far-padded": the cells' short search
pads them into one, `joint_buckets`, ODE models), every feature at once ("all": local, offset, delay, fitted initial
state; and on close lengths "all-derivative": the derivative start with the others); each on the
paper's DC motor (an ODE), the same motor as a discrete-time model (its Euler map) and a
two-input, three-state PMSM in the dq frame with a per-recording constant input; and on the motor
read through an output equation (`sensor`, `sensor-discrete`: a torque sensor cm i_a and a
sign-blind speed sensor |omega|, the reference's `dc_sensors`), the features that read the outputs
(`SENSOR_CELLS`). A cell per
feature and length (72) would not fit the test time: each compiles a search and a polish.

A cell checks composition and exactness, not the global search: the parameters start 3 % off the
truth in a box of -30 % .. +40 %, one population is evaluated and Levenberg-Marquardt polishes
the best. Every parameter and every extra (local copies, y0, offsets, delays) must then match the
truth to 1e-6 relative. The ODE cells integrate with RK4 at 4 sub-steps per sample against a
reference at 32 (both converged to better than 1e-9 of the peaks, `test_the_reference_converges`);
the discrete-time model's map is the reference's own, so its cells are exact to rounding.

The derivative cells use each model's encoder variant (the shaft angle measured instead of the
speed): the data start in steady motion with the inputs held over the first samples, so the angle
is linear there and the quadratic the derivative start fits is exact.

The fast set (`-m "not slow"`) runs every feature and every model at least once (`FAST`: each
cell compiles a search and a polish, about 5-10 s on 2 cores); the full run runs every cell,
and `fit_each` and `design_input` on each model."""

import dataclasses
import functools
import sys
from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
import reference as ref
from matrix_models import PMSM, EncoderDC, EncoderEulerDC, EncoderPMSM, EulerDC, SensorDC, SensorEulerDC

import dcjax
from dcjax.simulation.joint import padded

DT = 1e-4
TOL = 1e-6


@dataclasses.dataclass(frozen=True)
class Case:
    """One model of the matrix with its reference equations, its truth and its experiment."""

    model: dcjax.Model
    encoder: dcjax.Model  # the same with the angle measured instead of the speed
    field: Callable  # reference vector field (or discrete map)
    encoder_field: Callable
    steady: Callable  # the vector field whose rest point the data start at
    discrete: bool
    truth: dict
    levels: tuple  # per input that is recorded: the input's levels (held over the recording's quarters)
    constants: dict  # per-recording constant inputs (the model's last inputs)
    local: str  # the parameter a recording has its own value of (`local` cells)
    offset: str  # measured channel with a sensor offset
    delay: str  # delayed input
    fitted: str  # state whose initial value is fitted
    speed: str  # the speed state (a derivative of the angle in the encoder variant)
    measure: tuple[str, ...] = ()  # the states a `measure` cell compares (the others' columns still give their initial values)
    known: str | None = None  # the parameter a `measure` cell fixes at its truth (where the compared states leave a symmetry)
    sensors: Callable | None = None  # an output equation's reference (p, states) -> {output: values}; the states' columns give their starts


DC_TRUTH = dict(Ra=42.5, La=0.08, cm=0.4781, J=2e-5, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8)
PMSM_TRUTH = dict(Rs=0.5, Ld=1.0e-3, Lq=1.5e-3, psi=0.05, J=1e-4, B=2e-3, Tl=0.02)
DC_LEVELS = ((60.0, 220.0, 120.0, 180.0),)
DC_CASE = Case(
    dcjax.DC(),
    EncoderDC(),
    ref.dc_field,
    ref.dc_encoder_field,
    ref.dc_field,
    False,
    DC_TRUTH,
    DC_LEVELS,
    {},
    "Tla",
    "i_a",
    "u_a",
    "omega",
    "omega",
    measure=("omega",),  # with the current not compared, Ra/s, La/s, J s, Tla s, ... give the same speed: Ra known
    known="Ra",
)
CASES = {
    "dc": DC_CASE,
    "discrete": dataclasses.replace(  # the same motor, truth and experiment as its discrete-time (Euler) map
        DC_CASE, model=EulerDC(), encoder=EncoderEulerDC(), field=ref.dc_euler_map, encoder_field=ref.dc_encoder_euler_map, discrete=True
    ),
    "pmsm": Case(
        PMSM(),
        EncoderPMSM(),
        ref.pmsm_field,
        ref.pmsm_encoder_field,
        ref.pmsm_field,
        False,
        PMSM_TRUTH,
        ((0.5, -1.0, 1.5, 0.0), (2.0, 6.0, 3.0, 5.0)),
        {"pp": 4.0},
        "Tl",
        "id",
        "uq",
        "w",
        "w",
        measure=("id", "iq"),  # the currents alone: the speed enters both through pp w Lq iq and pp w (Ld id + psi)
    ),  # fmt: skip
}
SENSOR_CASE = dataclasses.replace(DC_CASE, model=SensorDC(), sensors=ref.dc_sensors, offset="torque")
CASES["sensor"] = SENSOR_CASE  # an output equation: an ODE model and a discrete-time one
CASES["sensor-discrete"] = dataclasses.replace(SENSOR_CASE, model=SensorEulerDC(), field=ref.dc_euler_map, discrete=True)
LENGTHS = {"one": (240,), "equal": (240, 240), "close": (240, 216), "far": (240, 120), "far-padded": (240, 120)}
FEATURES = (
    "plain",
    "local",
    "offset",
    "delay",
    "initial-fit",
    "initial-derivative",
    "initial-derived",
    "offset-smoothed",
    "measure",
    "zoh",
    "zoh-delay",
    "prediction",
)
# Joint fits take the features together (a cell compiles a search and a polish, 5-10 s on 2 cores:
# one cell per feature and length would not fit the test time): every feature at once, and the
# derivative start with the others on padded lengths.
COMBINED = {
    "all": ("local", "offset", "delay", "initial-fit"),
    "all-derivative": ("local", "offset", "delay", "initial-derivative"),
    "zoh-delay": ("zoh", "delay"),  # a held input delayed: the step moves whole
    "offset-smoothed": ("offset", "initial-smoothed"),  # the offset channel's state starts at its smoothed first samples less the offset
    "all-smoothed": ("local", "offset", "delay", "initial-smoothed"),  # the smoothed start in a joint fit of padded lengths
    "all-prediction": ("local", "offset", "delay", "initial-fit", "prediction"),  # every feature under the Kalman filter
}
JOINT = {"equal": ("all", "all-prediction"), "close": ("all", "all-derivative", "all-smoothed"), "far": ("all",), "far-padded": ("all",)}
# The output-equation cases: each feature that reads the outputs (offsets on an output, a local
# parameter, a delay, a held input, a fitted start of a state that is not an output) on one
# recording, and every one at once on two of equal length (no encoder variant: the derivative and
# measure cells are the state-output cases'; the lengths' cells do not read the outputs); `fit_each`
# and the design on the ODE one.
SENSOR_CELLS = {"one": ("local", "offset", "delay", "initial-fit", "zoh"), "equal": ("all", "all-prediction")}
# A prediction-error fit (an EKF, its noise given: q = 0 on noise-free data, the sensors' sd 1e-3 of
# the peaks) on one recording of the map, and with every feature on the motor's sensors (an ODE)
# (the PMSM's, 21 s, is not in the suite: its three states are the sensor case's question too).
PREDICTION_CELLS = {("discrete", "one"), ("sensor", "equal")}  # (dc, one) and (dc, equal) pass too: 21 s of the suite
# Its polish (BFGS on the likelihood, `fitting.polish`) stops where the weak terms (the load torque's,
# an offset) move the objective less than its tolerance: within 1e-3 (Ra, La, cm, J: 1e-7).
TOL_PREDICTION = 1e-3


def parts(feature: str) -> tuple[str, ...]:
    """The single features of a cell's feature (a combined one's several)."""
    return COMBINED.get(feature, (feature,))


FAST = {  # every feature, every model and a joint fit at least once; the other cells in the full run
    ("pmsm", "one", "delay"),
    ("dc", "equal", "all"),
    ("discrete", "one", "offset"),
    ("discrete", "one", "initial-derivative"),
    ("dc", "one", "initial-fit"),
    ("dc", "one", "initial-derived"),
    ("sensor", "equal", "all"),
    ("sensor-discrete", "one", "offset"),
}


def _inputs(case: Case, n: int, r: int) -> np.ndarray:
    """(n, M) inputs of recording r: each recorded input at its levels (scaled per recording),
    held for the first 12 samples, then over the thirds; the constants as columns."""
    cols = []
    edges = [0, 12, n // 3, 2 * n // 3, n]
    for levels in case.levels:
        u = np.empty(n)
        for k, level in enumerate(levels):
            u[edges[k] : edges[k + 1]] = level * (1.0 + 0.15 * r)
        cols.append(u)
    cols += [np.full(n, v) for v in case.constants.values()]
    return np.stack(cols, axis=1)


@functools.cache
def data(model_key: str, lengths_key: str, feature: str) -> tuple[tuple, dict]:
    """The recordings of a cell (from the reference) and the truth of every entry of its search vector."""
    case, f = CASES[model_key], parts(feature)
    encoder = "initial-derivative" in f or "initial-derived" in f
    model = case.encoder if encoder else case.model.measuring(case.measure) if "measure" in f else case.model
    field = case.encoder_field if encoder else case.field
    lengths = LENGTHS[lengths_key]
    truth: dict = {}
    recs = []
    for r, n in enumerate(lengths):
        p = dict(case.truth)
        if "local" in f:
            p[case.local] = case.truth[case.local] * (1.0 + 0.3 * r)
            truth[f"{case.local}[{r}]" if len(lengths) > 1 else case.local] = p[case.local]
        t = np.arange(n) * DT
        u = _inputs(case, n, r)
        y0 = ref.settle(case.steady, p, u[0], np.zeros(len(case.model.states)), 0.2)
        if encoder:
            y0 = np.append(y0, 0.0)  # the angle starts at 0
        delays = np.zeros(u.shape[1])
        if "delay" in f:
            delays[model.inputs.index(case.delay)] = 2.5 * DT
        held = (model.inputs.index(case.delay),) if "zoh" in f else ()
        if case.discrete:
            y = ref.iterate(field, p, t, u, y0, delays=delays, held=held)
        else:
            y = ref.simulate(field, p, t, u, y0, substeps=32, delays=delays, held=held)
        if case.sensors is not None:  # the outputs from the reference's sensors; the states' columns give their initial values
            channels = {s: y[:, k] for k, s in enumerate(model.states)} | case.sensors(p, y)
        else:
            channels = {c: y[:, model.states.index(c)] for c in (model.states if "measure" in f else model.outputs)}
        if "offset" in f:
            offset = 0.03 * float(np.max(np.abs(channels[case.offset])))
            truth.setdefault(f"offset_{case.offset}", offset)
            channels[case.offset] = channels[case.offset] + truth[f"offset_{case.offset}"]
        if "initial-fit" in f:
            truth[f"y0_{case.fitted}[{r}]" if len(lengths) > 1 else f"y0_{case.fitted}"] = float(y0[model.states.index(case.fitted)])
        if "initial-derived" in f:  # the default: the speed, the angle's derivative and not recorded, starts fitted
            truth[f"y0_{case.speed}[{r}]" if len(lengths) > 1 else f"y0_{case.speed}"] = float(y0[model.states.index(case.speed)])
        recorded = [c for c in model.inputs if c not in case.constants]
        channels |= {c: u[:, model.inputs.index(c)] for c in recorded}
        recs.append(dcjax.Recording(t=t, channels=channels, constants=case.constants or None, name=f"{model_key}-{lengths_key}-{r}"))
    if "delay" in f:
        truth[f"delay_{case.delay}"] = 2.5 * DT
    for n in model.names:
        if not ("local" in f and n == case.local):
            truth[n] = case.truth[n]
    return tuple(recs), truth


def initial_specs(case: Case, f: tuple[str, ...]) -> dict:
    """The cell's `initial`: a fitted start, a derivative start, a smoothed start (of the offset
    channel's state), or the defaults."""
    for feature, spec in (("initial-fit", {case.fitted: "fit"}), ("initial-derivative", {case.speed: "derivative"})):
        if feature in f:
            return spec
    return {case.offset: "smoothed"} if "initial-smoothed" in f else {}


def observation(case: Case, feature: str, recs: tuple = ()) -> dcjax.Observation:
    f = parts(feature)
    model = case.model
    sensors = {c: 1e-3 * max(float(np.max(np.abs(r[c]))) for r in recs) for c in model.outputs} if "prediction" in f else {}
    return dcjax.Observation(
        initial=initial_specs(case, f),
        offsets=(case.offset,) if "offset" in f else (),
        delays=(case.delay,) if "delay" in f else (),
        measure=case.measure if "measure" in f else None,
        hold={case.delay: "zoh"} if "zoh" in f else {},
        focus="prediction" if "prediction" in f else "simulation",
        process=dict.fromkeys(case.model.states, 0.0) if "prediction" in f else {},  # noise-free data: the filter is the simulation
        measurement=sensors,  # given: a sensor sd fitted to noise-free data runs to its bound, decades from the start
    )


def start_parameters(model: dcjax.Model, truth: dict, feature: str, case: Case, n_rec: int) -> dcjax.Parameters:
    """Every parameter 3 % off the truth (alternating in sign) in a box of -30 % .. +40 % around
    it; the observation's entries start 3 % off inside their automatic ranges."""
    out = []
    for k, n in enumerate(model.names):
        local = "local" in parts(feature) and n == case.local
        values = [truth[f"{n}[{r}]"] for r in range(n_rec)] if local and n_rec > 1 else [truth[n]]
        sign = 1.0 if k % 2 == 0 else -1.0
        if "measure" in parts(feature) and n == case.known:
            out.append(dcjax.Parameter(n, value=truth[n], min=0.7 * truth[n], max=1.4 * truth[n], vary=False))
            continue
        out.append(dcjax.Parameter(n, value=float(np.mean(values)) * (1 + 0.03 * sign), min=0.7 * min(values), max=1.4 * max(values),
                                   local=local))  # fmt: skip
    extras = {n.split("[")[0] for n in truth if n.startswith(("y0_", "offset_", "delay_"))}
    for n in sorted(extras):
        values = [v for k, v in truth.items() if k.split("[")[0] == n]
        out.append(dcjax.Parameter(n, value=float(np.mean(values)) * 1.03))
    return dcjax.Parameters(out)


def fit_cell(model_key: str, lengths_key: str, feature: str) -> tuple[dcjax.FitResult, dict]:
    case = CASES[model_key]
    recs, truth = data(model_key, lengths_key, feature)
    model = case.encoder if {"initial-derivative", "initial-derived"} & set(parts(feature)) else case.model
    params = start_parameters(model, truth, feature, case, len(recs))
    integrator = None if case.discrete else dcjax.RK4(substeps=4)
    res = dcjax.fit(list(recs), model, params, search=dcjax.Search(runs=1, budget=70, polish=True), observation=observation(case, feature, recs), integrator=integrator)  # fmt: skip
    return res, truth


def errors(res: dcjax.FitResult, truth: dict) -> dict[str, float]:
    return {n: abs(res.best_values[n] - v) / abs(v) for n, v in truth.items()}


CELLS = [
    pytest.param(m, ln, f, id=f"{m}-{ln}-{f}", marks=() if (m, ln, f) in FAST else pytest.mark.slow)
    for m in CASES
    for ln in LENGTHS
    for f in (FEATURES if ln == "one" else JOINT[ln])
    if not (ln == "far-padded" and CASES[m].discrete)  # a map is not padded: "far" is its cell
    if CASES[m].sensors is None or f in SENSOR_CELLS.get(ln, ())
    if not (
        m == "pmsm" and (ln, f) in (("far", "all"), ("close", "all"), ("close", "all-smoothed"))
    )  # the DC cells hold those lengths; 25 s of the suite
    if "prediction" not in parts(f) or (m, ln) in PREDICTION_CELLS
    if f != "initial-derived" or m == "dc"  # the default's start: one cell (the explicit fit and derivative starts have theirs)
]


@pytest.mark.parametrize("model_key,lengths_key,feature", CELLS)
def test_cell_recovers_the_truth(model_key, lengths_key, feature, monkeypatch):
    runs, padded_lengths = sys.modules["dcjax.fitting.runs"], []
    if lengths_key == "far":  # a scan each, as a long search keeps them (this short one would pad them into one, `joint_buckets`)
        monkeypatch.setattr(runs, "joint_buckets", lambda problems, fes, compile_fes: list(problems))
    elif lengths_key == "far-padded":  # padded into one scan: seen
        buckets = runs.joint_buckets
        monkeypatch.setattr(runs, "joint_buckets", lambda *a: padded_lengths.extend(p.n for p in buckets(*a)) or buckets(*a))
    res, truth = fit_cell(model_key, lengths_key, feature)
    assert lengths_key != "far-padded" or padded_lengths == [240, 240], padded_lengths
    assert set(res.best_values) == set(truth), (sorted(res.best_values), sorted(truth))
    err = errors(res, truth)
    if CASES[model_key].discrete and {"zoh", "delay"} <= set(parts(feature)):
        # a map reads a held input at t_k - d: the data see only the whole samples of d (the
        # objective is flat in between), so the delay is checked to its sample interval
        d = f"delay_{CASES[model_key].delay}"
        assert np.ceil(res.best_values[d] / DT - 1e-9) == np.ceil(truth[d] / DT - 1e-9), (res.best_values[d], truth[d])
        err.pop(d)
    assert max(err.values()) <= (TOL_PREDICTION if "prediction" in parts(feature) else TOL), {k: f"{v:.1e}" for k, v in err.items()}
    if (model_key, lengths_key, feature) in (("dc", "close", "all"), ("sensor", "one", "offset")):  # full run's cells
        held_out_start_is_estimated(res, model_key, lengths_key, feature)


def held_out_start_is_estimated(res: dcjax.FitResult, model_key: str, lengths_key: str, feature: str) -> None:
    """`validate(initial="estimate")` (findstates) of a fit (a joint one with a local parameter, an
    offset, a delay and a fitted start; an output equation with an offset on an output): its
    first recording, renamed (held out: the first recording's local values, offsets and delays),
    gets the reference's start back and its outputs to 1e-5 of their ranges."""
    case = CASES[model_key]
    rec = data(model_key, lengths_key, feature)[0][0]
    (v,) = res.validate([rec.replace(name="held-out")], initial="estimate")
    y0 = ref.settle(case.steady, case.truth, _inputs(case, 240, 0)[0], np.zeros(len(case.model.states)), 0.2)
    got = np.array([v.start[s] for s in case.model.states])
    assert np.max(np.abs(got - y0)) <= 1e-4 * np.max(np.abs(y0)), (got, y0)
    assert max(f["nrmse"] for f in v.channels.values()) < 1e-5, v.channels


@pytest.mark.slow
@pytest.mark.parametrize("model_key", ["dc", "pmsm"])
def test_the_reference_converges(model_key):
    """The reference at 32 sub-steps is within 1e-9 of the peaks of itself at 64, with a delay too
    (so it stands for the exact solution of the cells' ODE models)."""
    case = CASES[model_key]
    n = 240
    t = np.arange(n) * DT
    u = _inputs(case, n, 1)
    y0 = ref.settle(case.steady, case.truth, u[0], np.zeros(len(case.model.states)), 0.2)
    delays = np.zeros(u.shape[1])
    delays[case.model.inputs.index(case.delay)] = 2.5 * DT
    assert ref.converged(case.field, case.truth, t, u, y0, 32, delays=delays) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("model_key", [k for k in CASES if k != "sensor-discrete"])
def test_each_fits_every_recording_alone(model_key):
    """`fit_each` over recordings of three lengths (240, 216, 120 samples: at this budget one
    padded program for an ODE model, `dcjax.fitting.runs.bucketed`) and a file that does not exist: each
    recording recovers the truth on its own, its OF is its own unpadded one, the missing file
    fails alone."""
    case = CASES[model_key]
    close, truth = data(model_key, "close", "plain")
    recs = (*close, data(model_key, "far", "plain")[0][1])
    assert [len(r) for r in recs] == [240, 216, 120]
    params = start_parameters(case.model, truth, "plain", case, 1)
    integrator = None if case.discrete else dcjax.RK4(substeps=4)
    out = dcjax.fit_each(
        [*recs, "no/such/file.csv"], case.model, params, search=dcjax.Search(runs=1, budget=70, polish=True), integrator=integrator
    )
    assert isinstance(out[-1], dcjax.FailedFit) and "no such file" in out[-1].error.lower()
    for res, rec in zip(out[:-1], recs):
        assert isinstance(res, dcjax.FitResult)
        err = errors(res, truth)
        assert max(err.values()) <= TOL, {k: f"{v:.1e}" for k, v in err.items()}
        x = jnp.asarray([res.best_values[n] for n in res.names])
        target = res.target([rec])  # unpadded
        assert res.of == pytest.approx(float(target.objective(x)), rel=1e-6), rec.name  # ~1e-19: the rounding of the residuals
        away = x * 1.05  # where the OF is not a cancellation: the padded problem's is the same to rounding
        longer = eqx.tree_at(lambda t: t.problems, target, (padded(target.problems[0], 240),))
        assert float(longer.objective(away)) == pytest.approx(float(target.objective(away)), rel=1e-12), rec.name
    batch = [res.timing.get("batch", 1) for res in out[:-1]]
    assert batch == ([1, 1, 1] if case.discrete else [3, 3, 3]), (
        batch
    )  # one padded program; a discrete map is not padded (it would run past the end)


def test_length_buckets_minimise_compilations_plus_padded_search():
    from dcjax.simulation.joint import length_buckets

    lengths = [1000, 950, 500, 1000]
    assert length_buckets(lengths, fes=1.0, compile_fes=1e9) == {1000: 1000, 950: 1000, 500: 1000}  # a cheap search: one program
    assert length_buckets(lengths, fes=1e9, compile_fes=1.0) == {1000: 1000, 950: 950, 500: 500}  # a costly one: no padding
    # 950 padded to 1000 costs 5e7 < 1e8 saved; 500 padded costs 5e8 more
    assert length_buckets(lengths, fes=1e6, compile_fes=1e8) == {1000: 1000, 950: 1000, 500: 500}
    spread = np.unique(np.geomspace(400, 1600, 20).round().astype(int))
    for fes in (70, 2 * 140_000, 50 * 140_000):
        to = length_buckets(spread, fes, 1e9)
        cost = lambda buckets, fes=fes: sum(1e9 + fes * top * sum(v == top for v in buckets.values()) for top in set(buckets.values()))
        assert cost(to) <= min(cost({n: n for n in spread}), cost({n: spread.max() for n in spread}))  # no worse than either extreme


def test_bucket_tops_are_grid_lengths_the_same_for_similar_folders():
    """`length_buckets(..., per_octave=8)`: every top is a grid length at most 9 % above its
    members, so two folders of similar lengths (here each length 1-2 % off) get the same tops."""
    from dcjax.simulation.joint import length_buckets, on_length_grid

    grid = [on_length_grid(n) for n in range(1, 5000)]
    assert all(g >= n for n, g in zip(range(1, 5000), grid)) and grid == sorted(grid)
    assert max(g / n for n, g in zip(range(16, 5000), grid[15:])) <= 2 ** (1 / 8) + 1e-9 and len(set(grid)) < 110
    a = np.unique(np.geomspace(400, 1600, 20).round().astype(int))
    b = np.unique((a * np.linspace(1.01, 1.02, a.size)).round().astype(int))
    for fes in (70, 2 * 140_000):
        ta, tb = length_buckets(a, fes, 1e9, 8), length_buckets(b, fes, 1e9, 8)
        assert set(ta.values()) <= set(grid) and all(n <= top for n, top in ta.items())
        assert sorted(set(ta.values())) == sorted(set(tb.values())), (ta, tb)


# every feature once: "all" is local, offset, delay and a fitted initial state together
AUTO_CELLS = [
    ("dc", "equal", "all"),
    ("dc", "far", "all"),
    ("dc", "one", "zoh-delay"),
    ("pmsm", "one", "delay"),
    ("pmsm", "one", "measure"),
]


@pytest.mark.parametrize("model_key,lengths_key,feature", [pytest.param(*c, id="-".join(c), marks=() if c == ("dc", "equal", "all")
                                                                        else pytest.mark.slow) for c in AUTO_CELLS])  # fmt: skip
def test_nd_autos_reference_carries_every_feature(model_key, lengths_key, feature):
    """`AutoSubsteps`' adaptive diffrax reference (`dcjax.simulation.diffrax_reference`) at the
    truth, each recording with its own parameters (local), fitted initial state, delayed and held
    inputs, equals the independent NumPy reference's data (offsets added) to 1e-8 of the peaks
    (a fit with `AutoSubsteps` and the features: the next test)."""
    from dcjax.fitting.planning import plan
    from dcjax.simulation.diffrax_reference import reference_simulate_jit

    case = CASES[model_key]
    recs, truth = data(model_key, lengths_key, feature)
    model = case.model
    setup = plan(model, observation=observation(case, feature), integrator=dcjax.AutoSubsteps(dcjax.RK4())).setup(
        list(recs), start_parameters(model, truth, feature, case, len(recs))
    )
    x = jnp.asarray([truth.get(n, setup.params[n].value) for n in setup.space.names])
    layout = setup.target.layout
    for r, p in enumerate(setup.problems):
        adj = layout.adjustments(x, r, p)
        got = np.asarray(reference_simulate_jit(layout.model_x(x, r), p, adj))[:, list(p.model.output_index)]
        got = got + (0.0 if adj is None or adj.offset is None else np.asarray(adj.offset))
        err = np.max(np.abs(got - np.asarray(p.y_meas)) / np.max(np.abs(np.asarray(p.y_meas)), axis=0))
        assert err < 1e-8, (r, err)


@pytest.mark.slow  # the fast run has the reference above and the features' fit with RK4 (`test_cell_recovers_the_truth`)
@pytest.mark.parametrize("model_key,lengths_key,feature", [pytest.param(*c, id="-".join(c)) for c in AUTO_CELLS if c[1] != "far"])
def test_a_fit_with_nd_auto_takes_every_feature(model_key, lengths_key, feature):
    """A fit with `AutoSubsteps` takes local parameters, a fitted initial state, offsets, delayed
    and held inputs (once refused): its ND converges to the reference within the tolerance."""
    case = CASES[model_key]
    recs, truth = data(model_key, lengths_key, feature)
    res = dcjax.fit(list(recs), case.model, start_parameters(case.model, truth, feature, case, len(recs)), search=dcjax.Search(runs=1, budget=70, polish=True), observation=observation(case, feature), integrator=dcjax.AutoSubsteps(dcjax.RK4(), tol=1e-6))  # fmt: skip
    auto = res.settings["nd_auto"]
    assert auto["converged"] and auto["reference_error"] <= 1e-6 and set(res.best_values) == set(truth)


@pytest.mark.parametrize("model_key", ["dc", "discrete"])
def test_a_result_simulates_on_a_power_of_two_grid_to_the_same_bits(model_key):
    """`FitResult.simulate` pads the problem to `grid_length` (a folder's summary compiles a few
    programs) and cuts the padding off: the states are those of the unpadded problem, bit for bit."""
    from dcjax.fitting.simulated import _simulate
    from dcjax.fitting.simulated import simulate_on_grid as _simulate_on_grid
    from dcjax.simulation.joint import grid_length, joint_problem

    assert [grid_length(n) for n in (1, 64, 65, 240, 256, 257)] == [64, 64, 128, 256, 256, 512]
    case = CASES[model_key]
    (rec,), truth = data(model_key, "one", "plain")
    prob = dcjax.make_problem(rec, None if case.discrete else dcjax.RK4(substeps=4), model=case.model)
    target = joint_problem([prob])
    x = jnp.asarray([truth[n] for n in case.model.names])
    on_grid = _simulate_on_grid(x, target, 0)
    assert on_grid.shape == (240, len(case.model.states))
    np.testing.assert_array_equal(on_grid, np.asarray(_simulate(x, target, 0)))


@pytest.mark.slow
@pytest.mark.parametrize("model_key", [k for k in CASES if k != "sensor-discrete"])
def test_design_designs_every_recorded_input(model_key):
    """`design_input` on each model at its truth: every recorded input designed within its range,
    the per-recording constants held, every parameter identifiable (finite predicted errors), no
    NaN or overflow on the way (the two-input PMSM once held its second input and constant at 0
    and divided by 0); the recording's own inputs as a baseline have finite errors (once `inf %`)."""
    from dcjax.analysis.design import evaluate_input

    case = CASES[model_key]
    recorded = tuple(c for c in case.model.inputs if c not in case.constants)
    ranges = {c: (min(levels), max(levels)) for c, levels in zip(recorded, case.levels)}
    with np.errstate(all="raise"):
        d = dcjax.design_input(
            case.model, case.truth, duration=0.024, dt=DT, u_range=ranges, hold=2e-3, given=case.constants, starts=2, steps=5
        )
    assert d.inputs == recorded and d.recording.constants == case.constants
    for c in recorded:
        u = d.recording[c]
        assert ranges[c][0] <= u.min() and u.max() <= ranges[c][1]
    assert all(np.all(np.isfinite(d.recording[s])) for s in case.model.states)
    assert d.unidentifiable == [] and all(np.isfinite(v) and v > 0 for v in d.stderr.values()), d.stderr
    t = d.recording.t
    own = evaluate_input(d, case.model, {c: np.where(t < 0.012, levels[0], levels[1]) for c, levels in zip(recorded, case.levels)})
    assert all(np.isfinite(v) for v in own.stderr.values()), own.stderr


@pytest.mark.parametrize(
    "model_key,lengths_key,feature",
    [pytest.param(*c, id="-".join(c), marks=() if c == ("dc", "close", "all") else pytest.mark.slow)
     for c in [("dc", "close", "all"), ("discrete", "close", "all"), ("pmsm", "one", "initial-derivative")]],
)  # fmt: skip
def test_the_stopping_rule_composes_with_every_feature(model_key, lengths_key, feature):
    """`Search.stop` with every feature at once (local, offset, delay, fitted initial state; padded
    lengths; a discrete map; the derivative start): a rule loose enough to end every run after its
    second iteration ends it there, the polish still recovers the truth, and each run says so;
    `fit_each` of one recording likewise."""
    case = CASES[model_key]
    recs, truth = data(model_key, lengths_key, feature)
    model = case.encoder if "initial-derivative" in parts(feature) else case.model
    params = start_parameters(model, truth, feature, case, len(recs))
    integrator = None if case.discrete else dcjax.RK4(substeps=4)
    search = dcjax.Search(runs=2, budget=7000, polish=True, stop=dcjax.Converged(rtol=1.0, atol=1.0, patience=1))
    res = dcjax.fit(list(recs), model, params, search, observation=observation(case, feature), integrator=integrator)
    assert list(res.iterations) == [2, 2] and res.run_status == (dcjax.RunStatus.CONVERGED,) * 2
    err = errors(res, truth)
    assert max(err.values()) <= TOL, {k: f"{v:.1e}" for k, v in err.items()}
    if len(recs) == 1:  # one recording: fit_each too
        (each,) = dcjax.fit_each(list(recs), model, params, search, observation=observation(case, feature), integrator=integrator)
        assert isinstance(each, dcjax.FitResult) and each.run_status == res.run_status
