"""User-facing error types.

Every error a user can cause (bad config, bad input arrays, unknown names, unwritable output)
is raised as a subclass of :class:`AccFusionError` with one sentence that names the bad value
and what is allowed.  The CLI prints that sentence without a traceback.
"""


class AccFusionError(Exception):
    """Base class of the errors a user can cause."""


class ConfigError(AccFusionError, ValueError):
    """An invalid configuration value: names the field and the allowed values."""


class InputError(AccFusionError, ValueError):
    """Invalid input data (NaN, inf, negative ranges, mismatched shapes)."""
