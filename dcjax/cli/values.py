"""The command line's values: each flag's text made its type as the arguments are parsed
(argparse's `type=`), so that a command reads numbers, names and mappings, never text. A
malformed value is the parser's one-line error, which names the flag (`Parser.error`)."""

import argparse
import math

from ..errors import ConfigError
from ..models.priors import prior_from_spec


class Store(argparse._StoreAction):
    """argparse's `store`, except that a flag of pairs or names given again adds to them
    (`--bound Ra=0:10 --bound J=0:0.1` is `--bound Ra=0:10,J=0:0.1`), where argparse kept the last
    one alone; a pair given twice with two values, or a flag of numbers given twice, is an error."""

    def __call__(self, parser, namespace, values, option_string=None):
        before = getattr(namespace, self.dest, None)
        if option_string is not None and before is not None and before is not self.default and isinstance(values, (dict, tuple)):
            if isinstance(values, dict) and isinstance(before, dict):
                clash = next((k for k in values if k in before and before[k] != values[k]), None)
                if clash is not None:
                    parser.error(f"argument {option_string}: {clash} given twice ({before[clash]} and {values[clash]})")
                values = {**before, **values}
            elif isinstance(before, tuple) and all(isinstance(v, str) for v in (*before, *values)):
                values = tuple(dict.fromkeys((*before, *values)))
            else:
                parser.error(f"argument {option_string}: given twice; give its values once, comma-separated")
        setattr(namespace, self.dest, values)


class Parser(argparse.ArgumentParser):
    """argparse's parser whose errors (a malformed value, an unknown flag, a missing argument)
    are one `ConfigError` line, as every other bad input of the command line, instead of the
    usage and an exit; a flag of pairs or names given again adds to them (`Store`)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.register("action", None, Store)
        self.register("action", "store", Store)

    def error(self, message: str):  # pyright: ignore[reportIncompatibleMethodOverride]
        raise ConfigError(message)


def finite(text: str) -> float:
    """A finite number of `text`, or ValueError (no flag of these takes inf or nan)."""
    v = float(text)
    if not math.isfinite(v):
        raise ValueError(text)
    return v


def numbers(text: str) -> tuple[float, ...]:
    """`"1,2.5,3e-4"` -> (1.0, 2.5, 0.0003)."""
    try:
        return tuple(finite(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated finite numbers, got {text!r}") from None


def mapping(text: str) -> dict[str, str]:
    """`"a=x,b=y"` -> {"a": "x", "b": "y"}."""
    out = {}
    for item in text.split(","):
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise argparse.ArgumentTypeError(f"must be NAME=VALUE pairs separated by commas, got {item!r}")
        out[key.strip()] = value.strip()
    return out


def named_numbers(text: str) -> dict[str, float]:
    """`"Ra=42.5,Tlc=0"` -> {"Ra": 42.5, "Tlc": 0.0}."""
    out = {}
    for k, v in mapping(text).items():
        try:
            out[k] = finite(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"value of {k} must be a finite number, got {v!r}") from None
    return out


def names(text: str) -> tuple[str, ...]:
    """`"Tlb,Tlc"` -> ("Tlb", "Tlc")."""
    out = tuple(n.strip() for n in text.split(","))
    if not all(out):
        raise argparse.ArgumentTypeError(f"must be comma-separated names, got {text!r}")
    return out


def named_ranges(text: str) -> dict[str, tuple[float, float]]:
    """`"Ra=0:10,J=0:0.1"` -> {"Ra": (0.0, 10.0), "J": (0.0, 0.1)}."""
    out = {}
    for k, v in mapping(text).items():
        lo, sep, hi = v.partition(":")
        try:
            out[k] = (finite(lo), finite(hi))
        except ValueError:
            sep = ""
        if not sep:
            raise argparse.ArgumentTypeError(f"{k} needs LOWER:UPPER (finite numbers), got {v!r}")
    return out


def named_numbers_or_numbers(text: str) -> dict[str, float] | tuple[float, ...]:
    """NAME=VALUE pairs, or one number per parameter in the model's order (--precision)."""
    return named_numbers(text) if "=" in text else numbers(text)


def stop_rule(text: str) -> dict[str, float] | None:
    """--stop: `rtol=R,atol=A,patience=G` (any of them; the rest the rule's defaults), or `never`
    (None: every run spends its budget)."""
    if text.strip().lower() == "never":
        return None
    return named_numbers(text) if text.strip() else {}


def substeps(text: str) -> int | str:
    """--nd: a positive integer or 'auto'."""
    if text == "auto":
        return "auto"
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer or 'auto', got {text!r}")
    return n


def priors(text: str) -> dict[str, str]:
    """`--prior NAME=SPEC` (`;` also separates): name -> prior spec, checked."""
    out = {}
    for item in [part for part in text.split(";") if part.strip()]:
        name, sep, spec = item.partition("=")
        if not sep or not name.strip():
            raise argparse.ArgumentTypeError(f"must be NAME=SPEC, e.g. J=lognormal(1e-4,0.5), got {item!r}")
        try:
            out[name.strip()] = prior_from_spec(spec).spec
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return out
