"""The one error family of hybridlog.

Every failure caused by what a user gave (a log, a model file, an option) is raised as a
subclass of :class:`HybridlogError` whose message is one line naming the file, key, field or
line at fault.  The CLI turns these into exit code 2; nothing below the CLI prints or exits.
"""


class HybridlogError(Exception):
    """Base class of every error hybridlog raises on purpose."""


class ModelError(HybridlogError):
    """A model file (TOML) is malformed, names an unknown symbol or has a wrong shape."""


class LogError(HybridlogError):
    """A log is unreadable, lacks a mapped signal or holds values that cannot be used."""


class OptionError(HybridlogError):
    """A command-line option or estimator option has an invalid name or value."""


class OutputError(HybridlogError):
    """An output path cannot be written without destroying something the user has."""
