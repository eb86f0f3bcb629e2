"""Case files: TOML -> strict, typed, frozen config models (one module per physics:
:mod:`.scene`, :mod:`.solid`, :mod:`.soil`, :mod:`.fluid`, :mod:`.model`; reading in
:mod:`.loading`).

A case file is TOML. The presence of a table enables a physics module (``[solid.NAME]``
builds a TLSPH body named NAME); absent tables cost nothing. ``extends = "file.toml"``
(or a list of files, relative to the including file) merges shared fragments table by
table, the including file winning. ``--set key.path=value`` overrides any key; the value
is read as a TOML value, or as a plain string when it is not one.

Every error is a :class:`ConfigError` whose message names the file, the key path and what
is allowed; it never escapes as a traceback from the CLI (exit code 2).

>>> cfg = load_config(None, text='[case]\\nt_end = 1.0\\ndx = 0.1\\n'
...     '[solid.bar]\\nmaterial = {rho0 = 1000.0, E = 1e6, nu = 0.3}\\n'
...     'blocks = [{origin = [0.0, 0.0], size = [1.0, 0.2]}]\\n')
>>> cfg.solid["bar"].material.model, cfg.sph.kernel
('stvk', 'cubic_spline')
"""

from fsi_sph.config.fluid import FluidSection, PPESection, ShiftingSection, WallsSection
from fsi_sph.config.loading import apply_overrides, load_config, load_config_from_run
from fsi_sph.config.model import Config, CouplingSection, Probe
from fsi_sph.config.scene import CaseSection, GuardSection, SphSection
from fsi_sph.config.soil import Boundary, SoilBody
from fsi_sph.config.solid import SolidBody

__all__ = [
    "Boundary",
    "CaseSection",
    "Config",
    "CouplingSection",
    "FluidSection",
    "GuardSection",
    "PPESection",
    "Probe",
    "ShiftingSection",
    "SoilBody",
    "SolidBody",
    "SphSection",
    "WallsSection",
    "apply_overrides",
    "load_config",
    "load_config_from_run",
]
