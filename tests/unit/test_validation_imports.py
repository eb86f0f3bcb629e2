"""Every validation script imports: the long validation runs stay out of pytest, so an import
that a refactoring broke would otherwise only show when someone runs ``fsi-sph validate``
(moving the fos plots out of fsi_sph/strength_reduction.py broke the slope scripts' import
that way, 2026-12-06)."""

import importlib
from pathlib import Path

import pytest

SCRIPTS = sorted(p.stem for p in (Path(__file__).resolve().parents[2] / "validation").glob("*.py")
                 if p.stem != "__init__")


@pytest.mark.parametrize("name", SCRIPTS)
def test_validation_script_imports(name):
    importlib.import_module(f"validation.{name}")
