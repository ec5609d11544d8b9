"""The optional extras a function needs, imported when it is called, with a one-line error that
names the extra to install."""

import importlib

from .errors import ConfigError

EXTRAS = {"pandas": "notebook", "arviz": "notebook"}


def optional_module(name: str, what: str):
    """The module `name`, or a one-line `ConfigError`: `what` needs it, and which extra installs it."""
    try:
        return importlib.import_module(name)
    except ImportError:
        raise ConfigError(f"{what} needs {name}: pip install 'dcjax[{EXTRAS.get(name, name)}]'") from None
