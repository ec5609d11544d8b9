"""The errors dcjax raises at its boundary, one class to catch them all: `DcjaxError`, a
`ValueError` whose message is one line naming the field or value and what is accepted.

- `ConfigError`: an option, a setting or a parameter range (a search, an observation, an
  integrator, bounds, a command's arguments);
- `ModelError`: a model's name, definition or a name it does not have;
- `DataError`: a recording or a file's contents (`check`: the data check that found it, e.g.
  "nan", "time", "dead", or None); `ResultFileError`: a saved result that cannot be read as one.

Inside a search a candidate whose simulation blows up is not an error: its objective is +inf."""


class DcjaxError(ValueError):
    """A one-line error of dcjax's (a `ValueError`, so `except ValueError` still catches it)."""


class ConfigError(DcjaxError):
    """An option, setting or parameter range that dcjax does not accept."""


class ModelError(DcjaxError):
    """A model that cannot be resolved or used as given."""


class DataError(DcjaxError):
    """A recording or a file's contents that break a rule; `check` names the data check
    (`DataError("nan", "column 'omega' has NaN ...")` reads "nan: column 'omega' ...") or is None."""

    def __init__(self, check: str, message: str | None = None):
        if message is None:
            check, message = "", check
        super().__init__(f"{check}: {message}" if check else message)
        self.check = check or None


class ResultFileError(DataError):
    """A saved result file that cannot be read as one (its path and the field in the message)."""

    def __init__(self, message: str):
        super().__init__(message)


def finite_number(value, what: str, accepted: str = "a number") -> float:
    """`value` as a finite float, else a one-line `ConfigError`: "`what` must be `accepted`"."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{what} must be {accepted}, got {value!r}") from None
    if not number == number or number in (float("inf"), float("-inf")):
        raise ConfigError(f"{what} must be finite, got {value!r}")
    return number


def check_seed(value, what: str) -> None:
    """A one-line `ConfigError` unless `value` is an integer that JAX's keys take (int64:
    -2^63 <= value < 2^63); a larger one failed inside JAX ("Python int too large")."""
    if isinstance(value, bool) or not isinstance(value, int) and not (hasattr(value, "dtype") and value.dtype.kind in "iu"):
        raise ConfigError(f"{what} must be an integer, got {value!r}")
    if not -(2**63) <= int(value) < 2**63:
        raise ConfigError(f"{what} must be an integer in [-2^63, 2^63), got {value!r}")
