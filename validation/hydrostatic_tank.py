"""Hydrostatic tank: water at rest in an open tank for 1 s (cases/hydrostatic_tank.toml).

Reference: hydrostatics. ``errors.pressure_pct`` is the bottom pressure (interpolated at the
middle of the floor, y = 0, from fluid and wall particles) minus rho g H, relative to rho g H;
``values.max_speed_ratio`` is the largest particle speed after 1 s over sqrt(g H).
Records run coarse to fine.
"""

from __future__ import annotations

import math
from pathlib import Path

from validation.common import record, run_case, write_outputs

CASE = Path(__file__).resolve().parents[1] / "cases" / "hydrostatic_tank.toml"
LADDER = [0.04, 0.02, 0.01]   # m; H / dx = 25, 50, 100
QUICK = [0.04, 0.02]


def validate(quick, data_dir, out_dir):
    out_dir = Path(out_dir)
    records = []
    for dx in (QUICK if quick else LADDER):
        label = f"dx={dx:g}"
        sim, summary = run_case(CASE, [f"case.dx={dx}", "case.output_every=0.5"],
                                out_dir / label)
        cfg = sim.cfg
        g = abs(cfg.case.gravity[1])
        rho = cfg.fluid.material.rho0
        block = cfg.fluid.blocks[0]
        depth = block.size[1]
        x_mid = block.origin[0] + 0.5 * block.size[0]
        p_bottom = float(sim.fluid.pressure_at([[x_mid, block.origin[1]]])[0])
        p_ref = rho * g * depth
        ratio = sim.fluid.max_speed() / math.sqrt(g * depth)
        records.append(record(label, dx, summary,
                              {"pressure_pct": 100.0 * (p_bottom - p_ref) / p_ref},
                              {"max_speed_ratio": ratio, "p_bottom_Pa": p_bottom,
                               "p_ref_Pa": p_ref, "t_end_s": sim.t}))
    result = {"case": "hydrostatic_tank",
              "reference": "hydrostatics: bottom pressure rho g H, fluid at rest",
              "records": records}
    write_outputs(result, out_dir)
    return result
