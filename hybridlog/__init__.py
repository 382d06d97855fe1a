"""hybridlog: offline mode and state estimation for hybrid (switched) systems from logs."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("hybridlog")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
