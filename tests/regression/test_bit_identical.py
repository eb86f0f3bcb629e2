"""Safety net for refactoring: a few short scenes end bit for bit where the stored states say.

Each scene runs a few tens of steps at a coarse resolution, and every final array of every
body (plus each body's extra state, e.g. the fluid's stacked pressures, and the clock) must
equal the stored reference exactly (``np.array_equal``). The references live in
``tests/data/bit_identical.npz``; regenerate them deliberately (only after a change that is
meant to change the results) with

    NUMBA_NUM_THREADS=1 python -m tests.regression.test_bit_identical --regen

The references are bit-exact on the machine that made them (CPU model and numpy, scipy and
numba versions, stored with them): library kernels that dispatch on the CPU (SIMD sums, BLAS)
round differently elsewhere, so on another machine the arrays must agree to 1e-10 of each
array's largest value instead (the mu(I) layer's arrays differed by up to 1.8e-12 of their
largest value after 30 steps between two CPUs, x by 3e-18 m; a refactoring error is orders of
magnitude larger).

The scenes cover the fluid alone (dam break, shifting), fluid + elastic structure (the gate:
interface rows, implicit structure rows, collisions), a floating rigid body (rigid rows,
waterline rows), the mu(I) granular layer (implicit viscous step, incremental projection,
periodic x, trapezoid positions) and Drucker-Prager soil (a slope).
"""

import platform
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

from fsi_sph.config import load_config
from fsi_sph.simulation import Simulation
from tests.consistency.test_floating_box import CASE as FLOATING_BOX_CASE

ROOT = Path(__file__).resolve().parents[2]
CASES = ROOT / "cases"
DATA = ROOT / "tests" / "data" / "bit_identical.npz"

# the floating rigid box of tests/consistency/test_floating_box.py, at dx 0.012 (SCENES)
FLOATING_BOX = FLOATING_BOX_CASE

#: scene -> (case file or inline TOML, overrides, steps)
SCENES = {
    "dam_break": ("dam_break.toml", ["case.dx=0.05"], 30),
    "elastic_gate": ("dam_break_elastic_gate.toml", ["case.dx=0.0025"], 20),
    "floating_box": (FLOATING_BOX, ["case.dx=0.012"], 25),
    "mu_i_layer": ("bagnold.toml", ["case.dx=0.001"], 30),
    "granular_collapse": ("granular_collapse.toml", ["case.dx=0.02"], 20),
    "soil_slope": ("slope_1_granular.toml", ["case.dx=0.05"], 30),
}


def machine() -> str:
    """CPU model and the versions whose kernels the results' last bits depend on."""
    import scipy

    cpu = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    # the name alone ("AMD EPYC") hides the micro-architecture that numba compiles for: two
    # machines of that name differed at 1e-15 relative in the dam break (2026-12-06)
    import llvmlite.binding as llvm

    cpu = f"{cpu} ({llvm.get_host_cpu_name()})"
    return f"{cpu}; numpy {np.__version__}; scipy {scipy.__version__}; numba {numba.__version__}"


def same(got, want, exact):
    if got.dtype != want.dtype or got.shape != want.shape:
        return False
    if exact or not np.issubdtype(want.dtype, np.floating):
        return bool(np.array_equal(got, want))
    scale = float(np.max(np.abs(want), initial=0.0))
    return bool(np.allclose(got, want, rtol=0.0, atol=1e-10 * scale))


def run_scene(name):
    """Run one scene on one numba thread -> {key: array} of its final state."""
    src, over, steps = SCENES[name]
    if src.endswith(".toml"):
        cfg = load_config(CASES / src, over)
    else:
        cfg = load_config(None, over, text=src)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        sim = Simulation(cfg)
        for _ in range(steps):
            sim.step()
        state = sim.state()
    finally:
        numba.set_num_threads(threads)
    out = {f"{name}/clock/t": np.float64(sim.t), f"{name}/clock/step": np.int64(sim.n_steps)}
    for body, arrays in state.items():
        for field, v in arrays.items():
            out[f"{name}/{body}/{field}"] = np.asarray(v)
    return out


@pytest.fixture(scope="module")
def reference():
    if not DATA.exists():
        pytest.fail(f"{DATA} missing: run this file with --regen (see its docstring)")
    with np.load(DATA) as f:
        return {k: f[k] for k in f.files}


@pytest.fixture(scope="module")
def exact(reference):
    """Bit-exact on the machine that made the references; to 1e-10 elsewhere."""
    return str(reference.get("__machine__", "")) == machine()


@pytest.mark.parametrize("name", list(SCENES))
def test_bit_identical(name, reference, exact):
    got = run_scene(name)
    want = {k: v for k, v in reference.items() if k.startswith(f"{name}/")}
    assert sorted(got) == sorted(want), "the set of stored fields changed"
    diff = [k for k in want if not same(got[k], want[k], exact)]
    what = "bit-identical" if exact else "identical to 1e-10 (references made on another machine)"
    assert not diff, f"not {what}: {diff}"


def regenerate():
    out = {}
    for name in SCENES:
        out.update(run_scene(name))
        print(f"{name}: {sum(k.startswith(name + '/') for k in out)} arrays", flush=True)
    out["__machine__"] = np.array(machine())
    DATA.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(DATA, **out)
    print(f"wrote {DATA} ({DATA.stat().st_size} bytes)")


if __name__ == "__main__":
    if "--regen" not in sys.argv:
        sys.exit("usage: python -m tests.regression.test_bit_identical --regen")
    regenerate()
