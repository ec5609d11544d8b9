"""The installed package's version (a source tree that was not installed: "0+unknown")."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("dcjax")
except PackageNotFoundError:
    __version__ = "0+unknown"
