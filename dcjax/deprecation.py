"""One warning for every earlier spelling that still works (`dcjax.compat` holds the 0.1 names)."""

import warnings


def warn_deprecated(old: str, new: str, stacklevel: int = 3, since: str = "0.2") -> None:
    """A `DeprecationWarning`: `old` still works, `new` is the spelling since dcjax `since`."""
    warnings.warn(f"{old} is deprecated since dcjax {since}; use {new}", DeprecationWarning, stacklevel=stacklevel)
