"""`Parameters` (lmfit vocabulary): the one place a parameter's facts live — its value, search
range `min`/`max`, whether it is searched (`vary`), its unit, the memory-assistance precision
(paper Table 29) and, after an uncertainty analysis or an equation-error estimate, its `stderr`.

    params = dcjax.DC().parameters("table8")
    params["Tlc"].set(value=0.0, vary=False)
    params["Ra"].set(min=0.0, max=10.0)

A `Parameter` stands for its value in arithmetic, comparisons, `float()`, formatting and NumPy
(as lmfit's does): `result.params["Ra"] - 42.5`, `f"{result.params['J']:.3g}"`,
`np.array([result.params[n] for n in names])`.
"""

import dataclasses
import math
import numbers
import operator
from collections.abc import Iterator, Mapping, Sequence

import numpy as np

from ..errors import ConfigError
from ..extras import optional_module
from ..html_table import html_table
from ..numbers import to_uncertainty
from .priors import Prior, prior_from_spec


class _Unset:
    """The default of `Parameter.set`'s keywords: the field is left as it is (None is a value)."""

    def __repr__(self) -> str:
        return "unset"


_UNSET = _Unset()


def _arithmetic(op):
    """`op` of a `Parameter` with a number (or another parameter) as on its value, and reflected:
    (`__add__`, `__radd__`); for a comparison `op(a, b)` the reflected one is its mirror (`<`, `>`)."""

    def value(x):
        return float(x) if isinstance(x, Parameter) else x

    return (lambda self, o: op(float(self), value(o))), (lambda self, o: op(value(o), float(self)))


@dataclasses.dataclass(eq=False)
class Parameter:
    """One parameter: `value` (None: not known; a varying parameter's value seeds the search),
    range `[min, max]`, `vary` (False: fixed at `value`), `unit`, `precision`, `stderr`,
    `local` (a joint fit gives each recording its own value, searched with the shared ones),
    `positive` (never below 0: automatic ranges and first estimates keep its sign), `scale`
    ("linear", or "log": searched and polished on log(value), uniform in decades between `min` > 0
    and `max`; implies `positive`) and `prior` (a `dcjax.models.priors.Prior` or its spec string
    for posterior sampling; None: uniform in the range, log-uniform on a log scale)."""

    name: str
    value: float | None = None
    min: float = -math.inf
    max: float = math.inf
    vary: bool = True
    unit: str = ""
    precision: float | None = None
    stderr: float | None = None
    local: bool = False
    positive: bool = False
    scale: str = "linear"
    prior: Prior | None = None

    def __post_init__(self):
        self.set(positive=self.positive, scale=self.scale, prior=self.prior)

    def set(
        self,
        value: float | None | _Unset = _UNSET,
        *,
        min: float | None | _Unset = _UNSET,
        max: float | None | _Unset = _UNSET,
        vary: bool | _Unset = _UNSET,
        precision: float | None | _Unset = _UNSET,
        stderr: float | None | _Unset = _UNSET,
        local: bool | _Unset = _UNSET,
        positive: bool | _Unset = _UNSET,
        scale: str | _Unset = _UNSET,
        prior: "Prior | str | None | _Unset" = _UNSET,
    ) -> "Parameter":
        """Change fields by keyword (lmfit's `Parameter.set`); returns the parameter."""
        for field, v in (("value", value), ("min", min), ("max", max), ("precision", precision), ("stderr", stderr)):
            if v is _UNSET:
                continue
            if v is not None or field in ("value", "precision", "stderr"):
                v = None if v is None else _number(v, f"{self.name}.{field}", allow_inf=field in ("min", "max"))
            setattr(self, field, v)
        for field, v in (("vary", vary), ("local", local), ("positive", positive)):
            if v is not _UNSET:
                if not isinstance(v, (bool, np.bool_)):
                    raise ConfigError(f"{self.name}.{field} must be True or False, got {v!r}")
                setattr(self, field, bool(v))
        if not isinstance(scale, _Unset):
            if scale not in ("linear", "log"):
                raise ConfigError(f"{self.name}.scale must be 'linear' or 'log', got {scale!r}")
            self.scale = str(scale)
            self.positive = self.positive or scale == "log"
        if prior is not _UNSET:
            try:
                self.prior = None if prior is None else prior_from_spec(prior)  # pyright: ignore[reportArgumentType]
            except ValueError as e:
                raise ConfigError(f"{self.name}: {e}") from None
        if self.positive and self.min == -math.inf:
            self.min = 0.0  # a positive parameter's range starts at 0 unless given
        if self.positive and self.min < 0:
            raise ConfigError(f"{self.name} is positive: its min must be >= 0, got {self.min:g}")
        return self

    # -- the value in arithmetic (lmfit's Parameter does the same) ------------------------------
    def __float__(self) -> float:
        if self.value is None:
            raise ConfigError(f"parameter {self.name} has no value")
        return float(self.value)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        return np.asarray(float(self), dtype=dtype)

    def __format__(self, spec: str) -> str:
        return format(float(self), spec) if spec else str(self)

    def __repr__(self) -> str:
        se = "" if self.stderr is None else f" +/- {self.stderr:.3g}"
        fixed = "" if self.vary else " (fixed)"
        local = " (local)" if self.local else ""
        flags = " (log)" if self.scale == "log" else " (positive)" if self.positive else ""
        prior = "" if self.prior is None else f", prior={self.prior.spec}"
        return f"<Parameter {self.name!r}, value={self.value!r}{se}, bounds=[{self.min:g}:{self.max:g}]{fixed}{local}{flags}{prior}>"

    def __eq__(self, other) -> bool:
        """Another `Parameter`: every field equal; a number: the value equal."""
        if isinstance(other, Parameter):
            return dataclasses.astuple(self) == dataclasses.astuple(other)
        if isinstance(other, (numbers.Real, np.ndarray)):
            return self.value is not None and self.value == other  # pyright: ignore[reportReturnType]
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __neg__(self) -> float:
        return -float(self)

    def __pos__(self) -> float:
        return float(self)

    def __abs__(self) -> float:
        return abs(float(self))

    def __round__(self, ndigits: int | None = None):
        return round(float(self), ndigits)

    __add__, __radd__ = _arithmetic(operator.add)
    __sub__, __rsub__ = _arithmetic(operator.sub)
    __mul__, __rmul__ = _arithmetic(operator.mul)
    __truediv__, __rtruediv__ = _arithmetic(operator.truediv)
    __pow__, __rpow__ = _arithmetic(operator.pow)
    __lt__, __gt__ = _arithmetic(operator.lt)
    __le__, __ge__ = _arithmetic(operator.le)

    @property
    def relative_stderr(self) -> float | None:
        if self.stderr is None or self.value is None:
            return None
        return self.stderr / abs(self.value) if self.value else math.inf


def _number(v, what: str, allow_inf: bool = False) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ConfigError(f"{what} must be a number, got {v!r}") from None
    if math.isnan(f) or (math.isinf(f) and not allow_inf):
        raise ConfigError(f"{what} must be a finite number, got {v!r}")
    return f


class Parameters(Mapping[str, Parameter]):
    """An ordered name -> `Parameter` mapping in a model's parameter order."""

    def __init__(self, parameters: "Sequence[Parameter] | Parameters" = ()):
        self._items = {p.name: dataclasses.replace(p) for p in (parameters.values() if isinstance(parameters, Parameters) else parameters)}

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._items[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; the parameters are {', '.join(self._items)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return f"Parameters({', '.join(f'{n}={p.value!r}' for n, p in self._items.items())})"

    def to_dataframe(self):
        """The table as a pandas DataFrame indexed by name: value, stderr, relative stderr (of
        |value|), min, max, vary, unit, local, scale. Needs pandas (`dcjax[notebook]`)."""
        pd = optional_module("pandas", "Parameters.to_dataframe")
        rows = {}
        for n, p in self._items.items():
            rel = abs(p.stderr / p.value) if p.stderr is not None and p.value else None
            rows[n] = {"value": p.value, "stderr": p.stderr, "rel_stderr": rel, "min": p.min, "max": p.max, "vary": p.vary, "unit": p.unit,
                       "local": p.local, "scale": p.scale}  # fmt: skip
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "name"
        return df

    def copy(self) -> "Parameters":
        return Parameters(self)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._items)

    def valuesdict(self) -> dict[str, float | None]:
        return {n: p.value for n, p in self._items.items()}

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        """The values in order (lmfit's `np.array(params)`)."""
        return np.array([float(p) for p in self._items.values()], dtype=dtype)

    @property
    def lower(self) -> np.ndarray:
        return np.array([p.min for p in self._items.values()], float)

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.max for p in self._items.values()], float)

    @property
    def fixed(self) -> dict[str, float]:
        """Name -> value of the parameters that are not searched."""
        out = {}
        for n, p in self._items.items():
            if not p.vary:
                if p.value is None:
                    raise ConfigError(f"parameter {n} is fixed (vary=False) but has no value")
                out[n] = float(p.value)
        return out

    @property
    def start(self) -> dict[str, float]:
        """Values of the searched parameters that have one (they seed the initial population)."""
        return {n: float(p.value) for n, p in self._items.items() if p.vary and p.value is not None}

    @property
    def precision(self) -> dict[str, float] | None:
        prec = {n: p.precision for n, p in self._items.items()}
        return None if any(v is None for v in prec.values()) else prec  # pyright: ignore[reportReturnType]

    def check(self, names: tuple[str, ...], model_name: str = "the model") -> None:
        """The parameters must be exactly `names`, with finite ranges min <= max for the searched ones."""
        if tuple(self._items) != tuple(names):
            raise ConfigError(f"params must name {model_name}'s parameters {', '.join(names)} in order, got {', '.join(self._items)}")
        for n, p in self._items.items():
            if p.vary and not (math.isfinite(p.min) and math.isfinite(p.max)):
                raise ConfigError(f"parameter {n} needs a finite min and max to be searched, got [{p.min}, {p.max}]")
            if p.vary and p.min > p.max:
                raise ConfigError(f"parameter {n}: min {p.min:g} is above max {p.max:g}")

    def to_dict(self) -> dict[str, dict]:
        def clean(v):
            return None if isinstance(v, float) and not math.isfinite(v) else v

        def fields(p: Parameter) -> dict:
            d = {f.name: getattr(p, f.name) for f in dataclasses.fields(p) if f.name != "name"}
            d["prior"] = None if p.prior is None else p.prior.spec
            return {k: clean(v) for k, v in d.items() if not (k in ("local", "prior") and not v)}

        return {n: fields(p) for n, p in self._items.items()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Mapping]) -> "Parameters":
        out = []
        for n, f in d.items():
            f = dict(f)
            f["min"] = -math.inf if f.get("min") is None else f["min"]
            f["max"] = math.inf if f.get("max") is None else f["max"]
            out.append(Parameter(name=n, **f))
        return cls(out)

    def _rows(self) -> list[tuple[str, str, str, str, str, str, str, str]]:
        """name, value (to two significant digits of its std. error where known, else 6), std. error,
        relative, min, max, vary, unit."""
        out = []
        for n, p in self._items.items():
            known = p.stderr is not None and math.isfinite(p.stderr) and p.stderr > 0
            v = "-" if p.value is None else to_uncertainty(p.value, p.stderr) if known else f"{p.value:.6g}"  # pyright: ignore[reportArgumentType]
            se = "-" if p.stderr is None else f"{p.stderr:.2g}"
            rel = p.relative_stderr
            r = "-" if rel is None else ("> 1000%" if rel > 10 else f"{100 * rel:.2g}%") if math.isfinite(rel) else "inf"
            out.append((n, v, se, r, f"{p.min:.4g}", f"{p.max:.4g}", str(p.vary), p.unit))
        return out

    def table(self) -> str:
        """A fixed-width table: value, std. error, range, vary, unit."""
        lines = [f"{'name':>6} {'value':>13} {'stderr':>10} {'rel.':>8} {'min':>11} {'max':>11} {'vary':>5} unit"]
        for n, v, se, r, lo, hi, vary, unit in self._rows():
            lines.append(f"{n:>6} {v:>13} {se:>10} {r:>8} {lo:>11} {hi:>11} {vary:>5} {unit}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        """The table for a notebook (`table`'s columns)."""
        return html_table(f"Parameters ({len(self)})", ("name", "value", "stderr", "rel.", "min", "max", "vary", "unit"), self._rows())

    __str__ = table
