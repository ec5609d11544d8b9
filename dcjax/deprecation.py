"""One warning for every 0.1 spelling that still works (`dcjax.compat` holds the 0.1 names)."""

import warnings


def warn_deprecated(old: str, new: str, stacklevel: int = 3) -> None:
    """A `DeprecationWarning`: `old` still works, `new` is the 0.2 spelling."""
    warnings.warn(f"{old} is deprecated since dcjax 0.2; use {new}", DeprecationWarning, stacklevel=stacklevel)
