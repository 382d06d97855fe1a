"""hybridlog: offline mode and state estimation for hybrid (switched) systems from logs."""

__version__ = "0.1.0"
"""The one place the version is written (``pyproject.toml`` reads it from here): every command
imports this package, and a lookup through ``importlib.metadata`` costs about 0.06 s."""

__all__ = ["__version__"]
