"""Numbers as text, for a person and for a file: a value to the digits its uncertainty justifies
(two significant digits of the uncertainty, the GUM's convention, JCGM 100:2008 7.2.6), and for
a table written to a file the shortest text that reads back as the same float64 (`repr`, which
writes 0.0324 where `%.17g` writes 0.032399999999999998)."""

import math

import numpy as np

MOST_DIGITS = 15  # float64 holds 15 significant decimal digits that survive a round trip


def plain(x: float) -> str:
    """The shortest decimal text that reads back to the same float64: `0.0324`, `1e-05`, `nan`."""
    return repr(float(x))


def plain_rows(table: np.ndarray) -> list[str]:
    """Each row of a 2-D table as comma-separated `plain` numbers (a CSV's body, lossless)."""
    return [",".join(map(plain, row)) for row in np.asarray(table, dtype=float).tolist()]


def csv_text(columns: list[str], table: np.ndarray) -> str:
    """A CSV: the header, then each row of `table` in `plain` numbers."""
    return "\n".join([",".join(columns), *plain_rows(table)]) + "\n"


def significant_digits(value: float, uncertainty: float) -> int:
    """How many significant digits of `value` an `uncertainty` justifies: down to the second
    significant digit of the uncertainty (one where the uncertainty exceeds the value ten times
    over), at most 15."""
    if not (math.isfinite(value) and math.isfinite(uncertainty)) or uncertainty <= 0:
        return MOST_DIGITS
    if value == 0:
        return 1
    digits = math.floor(math.log10(abs(value))) - math.floor(math.log10(uncertainty)) + 2
    return int(min(MOST_DIGITS, max(1, digits)))


def to_uncertainty(value: float, uncertainty: float) -> str:
    """`value` rounded at the second significant digit of `uncertainty`, significant trailing zeros
    kept: (42.49673, 0.013) -> '42.497'; (0.01, 1e-14) -> '0.010000000000000'; (3.27e-05, 2.1e-07)
    -> '3.270e-05'; a value the uncertainty cannot tell from 0 is a zero at that digit:
    (0.0008, 0.11) -> '0.00'. Fixed-point down to 1e-4, scientific below (and at 1e6 and above)."""
    if not math.isfinite(value):
        return str(value)
    if not math.isfinite(uncertainty) or uncertainty <= 0:
        return format(value, f".{MOST_DIGITS}g")
    last = max(math.floor(math.log10(uncertainty)) - 1, math.floor(math.log10(abs(value))) - MOST_DIGITS + 1 if value else -400)
    rounded = round(value, -last)
    if -4 <= last and abs(rounded) < 1e6:
        return format(abs(rounded) if rounded == 0 else rounded, f".{max(0, -last)}f")
    digits = math.floor(math.log10(abs(rounded))) - last + 1 if rounded else 0
    if digits < 1:  # zero at the digit `last`: one decimal of a mantissa scaled by 10^(last + 1)
        return f"0.0e{last + 1:+03d}"
    text = format(rounded, f"#.{digits}g")
    return text[:-1] if text.endswith(".") else text.replace(".e", "e")


__all__ = ["csv_text", "plain", "plain_rows", "significant_digits", "to_uncertainty"]
