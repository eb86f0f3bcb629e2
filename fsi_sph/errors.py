"""The errors every layer may raise or catch, in one module that imports nothing of fsi_sph.

- :class:`ConfigError`: a case file or override that cannot be used (CLI exit code 2).
- :class:`UsageError`: bad input given on the command line (exit code 2).
- :class:`SimulationError`: a run that cannot go on (exit code 1).
"""


class ConfigError(Exception):
    """A case file or override that cannot be used; the message says where and why."""


class UsageError(Exception):
    """Bad input given on the command line (exit code 2)."""


class SimulationError(RuntimeError):
    """A run that cannot go on; the message says when, where and why."""
