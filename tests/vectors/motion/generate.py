"""Write (``--refresh``) or check the motion test vectors from the Python reference.

Each case below is a small G-code job, a machine and a planner; the vector
holds what :mod:`labkit.motion` makes of it, block by block and tick by tick
(schema in README.md). The C firmware's tests read the same files.

    .venv/bin/python tests/vectors/motion/generate.py            # check, exit 1 on a difference
    .venv/bin/python tests/vectors/motion/generate.py --refresh  # rewrite the JSON files
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from labkit.gcode import grbl_sync_lines, parse
from labkit.motion import load_machine, plan
from labkit.motion.blocks import BlockKind
from labkit.motion.timer import block_points, step_blocks, tick_power_mw, tick_rates, timer_period

HERE = Path(__file__).resolve().parent
SCHEMA = "labkit-motion-vector/1"

#: The labkit firmware plans every ramp from and to its start rate: it has no
#: ``MachineSpec.rest_at_zero`` (GRBL's planner rests at 0), so every case is made with it false
#: and the vectors leave the key out (the firmware's tests read them).
FIRMWARE_REST = dict(rest_at_zero=False)

#: The grbl-diode description with the 250 Hz start/stop floor it had until issue 29 (it has
#: GRBL's 31 Hz since): the floor regressions below need a rest speed that high to arise.
FLOOR_250_HZ = dict(start_rate_hz=250, prescaler=0, **FIRMWARE_REST)

CASES = {
    "lines_2d_hq": dict(
        description="2-D lines in all eight octants and on the axes, high-quality MBLA, linear ramps",
        machine="cbr40-laser", planner="hq",
        gcode="G21 G90\nM4 S400\nG1 X0.03 Y0.01 F600\nG1 X0.05 Y0.04\nG1 X0.04 Y0.07\n"
              "G1 X0.01 Y0.08\nG1 X-0.02 Y0.06\nG1 X-0.03 Y0.03\nG1 X-0.02 Y0.0\nG1 X0.01 Y-0.02\n"
              "G1 X0.01 Y0.0\nG1 X0.0 Y0.0\nM5\n"),
    "lines_3d_junction": dict(
        description="3-axis lines with GRBL's junction-deviation planner, constant acceleration",
        machine="cbr40-laser", planner="junction",
        gcode="G21 G90\nG1 X0.02 Y0.01 Z0.005 F900\nG1 X0.03 Y0.03 Z0.0\nG1 X0.0 Y0.04 Z-0.01\n"
              "G0 X0 Y0 Z0\n"),
    "arcs_normal": dict(
        description="G2/G3 arcs walked by octants: quarter, half with an off-lattice centre, "
                    "a full circle and a helix; normal MBLA",
        machine="cbr40-laser", planner="normal",
        gcode="G21 G90\nM3 S250\nG0 X0.02 Y0\nG3 X0 Y0.02 I-0.02 J0 F300\n"
              "G2 X0.0107 Y0.0301 I0.00535 J0.00505\nG0 X0.03 Y0.0\nG3 X0.03 Y0 I-0.015 J0\n"
              "G2 X0.03 Y0.01 Z0.004 I0 J0.005\nM5\n"),
    "zigzag_fast": dict(
        description="A small zig-zag raster with power steps and dark step-overs, fast MBLA "
                    "(one ramp up and one down per super block), buffer of 4 blocks",
        machine="cbr40-laser", planner="fast", buffer_blocks=4,
        gcode="G21 G90\nM4 S600\nG1 X0.03 Y0 F1200\nG1 X0.06 S300\nG1 Y0.005 S0\nG1 X0.03 S600\n"
              "G1 X0 S300\nG1 Y0.01 S0\nG1 X0.06 S600\nM5\n"),
    "dwell_rapid_grbl_diode": dict(
        description="Rapids, a dwell and cuts on the GRBL diode machine (80 steps/mm, 16 MHz timer)",
        machine="grbl-diode", machine_fields=FIRMWARE_REST, planner="junction",
        gcode="G21 G90\nG0 X1 Y0.5\nM3 S1000\nG1 X1.5 Y0.5 F1500\nG4 P0.05\nG1 X1.5 Y1.0\nM5\nG0 X0 Y0\n"),
    "short_blocks_buffer1_fast": dict(
        description="Short blocks through a one-block look-ahead, fast MBLA on the GRBL diode "
                    "machine: the window's end speed must let the next block slow to its rest "
                    "speed (the reference used to refuse this job)",
        machine="grbl-diode", machine_fields=FLOOR_250_HZ, planner="fast", buffer_blocks=1,
        gcode="G21 G90\nM3 S583\nG1 X0 Y0 F600\nG1 X-0.0554 Y-0.0073 F8070\n"
              "G1 X-0.0361 Y-0.0211 F8406 S470\nG1 X0.0488 Y0.0710 S248\nG1 X0.0183 Y0.0907 F2100\n"),
    "slow_neighbour_depth3_fast": dict(
        description="Short blocks at feeds from 12 to 140 mm/s through a three-block look-ahead, "
                    "fast MBLA on the GRBL diode machine: a block has to slow only to its floor "
                    "(rest speed), below which the junction changes speed at once; before, the "
                    "window ended lower than a later window could keep, and the reference refused "
                    "the job (block 19: 5.02 → 4.33 mm/s within 0.018 mm)",
        machine="grbl-diode", machine_fields=FLOOR_250_HZ, planner="fast", buffer_blocks=3,
        gcode="G21 G90\nM3 S231\nG1 X0 Y0 F600\nG1 X0.0104 Y0.0291 F6771\nG1 X-0.0111 Y0.0150\n"
              "G1 X0.0176 Y0.0190 F717\nG1 X0.0109 Y0.0384 F2199 S320\nG0 X0.0375 Y0.0496\n"
              "G1 X0.0219 Y0.0725 S312\nG1 X0.0512 Y0.0741\nG1 X0.0639 Y0.0746 F8238\n"
              "G1 X0.0504 Y0.0902 F5295 S852\nG1 X0.0626 Y0.1054 F1953\nG1 X0.0849 Y0.0856\n"
              "G0 X-0.0476 Y0.0079\nG0 X-0.0458 Y0.0097\nG1 X-0.0436 Y-0.0035\n"
              "G1 X-0.0250 Y-0.0168 S389\nG1 X-0.0245 Y-0.0019 S842\nG0 X-0.0242 Y0.0272\n"
              "G1 X-0.0209 Y0.0483\nG0 X0.0353 Y-0.0319\nG1 X0.0129 Y-0.0086 F7116 S448\n"
              "G1 X-0.0026 Y-0.0001\nG1 X-0.0024 Y0.0116 F7329\nG0 X0.0226 Y0.0343\n"
              "G1 X0.0109 Y0.0345\nG1 X-0.0079 Y0.0574 F7386\nM5\n"),
    "slow_neighbour_depth1_fast_3d": dict(
        description="Short 3-D blocks, dwells, feeds from 5 to 124 mm/s, one-block look-ahead: "
                    "a block next to a slower one exits at its own floor and the slower one "
                    "enters at its own (the reference refused it: block 12 from 3.38 to 1.95 mm/s "
                    "within 0.0125 mm)",
        machine="grbl-diode", machine_fields=FLOOR_250_HZ, planner="fast", buffer_blocks=1,
        gcode="G21 G90\nM3 S163\nG1 X0 Y0 F600\nG1 X-0.0102 Y0.0235 Z-0.0013 F753 S911\n"
              "G1 X0.0081 Y0.0425 Z-0.0051 S433\nG1 X-0.0024 Y0.0553 Z-0.0028 F7431\n"
              "G1 X-0.0282 Y0.0568 Z-0.0059 S671\nG1 X-0.0021 Y0.0763 Z-0.0053 F4785 S703\n"
              "G1 X0.0166 Y0.0570 Z-0.0024\nG1 X0.0394 Y0.0361 Z-0.0068\nG4 P0.001\n"
              "G1 X0.0679 Y0.0560 Z-0.0059\nG1 X0.0420 Y0.0363 Z-0.0034 F570 S262\n"
              "G1 X0.0307 Y0.0421 Z-0.0015\nG1 X0.0040 Y0.0521 Z-0.0017 F309\n"
              "G1 X-0.0146 Y0.0246 Z-0.0011 F618\nG1 X-0.0156 Y0.0437 Z-0.0011\n"
              "G1 X-0.0146 Y0.0269 Z-0.0047 F1275 S957\nG1 X0.0066 Y0.0116 Z-0.0049 F1566\n"
              "G1 X-0.0040 Y-0.0092 Z-0.0034 F2187\nG1 X0.0233 Y-0.0101 Z-0.0030 F6153 S247\n"
              "G4 P0.010\nG4 P0.002\nG1 X0.0455 Y-0.0243 Z0.0016\nG1 X0.0457 Y-0.0101 Z0.0037 F5811\n"
              "G1 X0.0163 Y-0.0268 Z0.0069 F1149\nG4 P0.000\nG1 X0.0417 Y-0.0496 Z0.0032 F7425 S780\n"
              "G1 X0.0379 Y-0.0446 Z0.0012 F3627\nG1 X0.0585 Y-0.0480 Z0.0021 F6987\n"
              "G1 X0.0342 Y-0.0322 Z0.0019 F2934 S231\nG1 X0.0234 Y-0.0225 Z-0.0012\n"
              "G1 X0.0295 Y-0.0319 Z-0.0008 S423\nG1 X0.0303 Y-0.0184 Z0.0016 F792\n"
              "G1 X0.0112 Y-0.0450 Z0.0029\nG1 X0.0398 Y-0.0682 Z-0.0010\n"
              "G1 X0.0595 Y-0.0800 Z-0.0048 F4590 S74\nG1 X0.0464 Y-0.1042 Z-0.0005 F1692 S265\n"
              "G0 X-0.0180 Y-0.0035\nG1 X-0.0151 Y0.0232 Z-0.0014 F2493 S201\nG0 X0.0228 Y-0.0050\n"
              "G1 X0.0337 Y-0.0012 Z-0.0049\nG1 X0.0633 Y0.0150 Z-0.0075 F990\nM5\n"),
}


def _floats(a):
    return [float(x) for x in np.asarray(a, float)]


def make_vector(name: str) -> dict:
    """Build one vector from the reference."""
    case = CASES[name]
    m = load_machine(case["machine"]).replace(**case.get("machine_fields", {}))
    if m.rest_at_zero:
        raise ValueError(f"{name}: the firmware plans from its start rate; give rest_at_zero=False")
    moves = parse(case["gcode"], dialect="grbl")
    # the machine stops where GRBL syncs (a laser or coolant switch between moves), as the
    # firmware's grbl dialect does
    p = plan(moves, m, planner=case["planner"], buffer_blocks=case.get("buffer_blocks"),
             sync_lines=grbl_sync_lines(case["gcode"]))
    sb = step_blocks(p)
    blocks = p.blocks
    pos = np.full(len(blocks), -1)
    pos[p.motion] = np.arange(len(p.motion))
    prof = p.profiles
    out_blocks = []
    clock = 0
    for i in range(len(blocks)):
        row = sb.row(i)
        kind = "RAPID" if blocks.rapid[i] else BlockKind(blocks.kind[i]).name
        entry = {"line": int(blocks.line[i]), "kind": kind}
        if blocks.kind[i] == BlockKind.DWELL:
            entry["dwell_cycles"] = row["dwell_cycles"]
            clock += row["dwell_cycles"]
            out_blocks.append(entry)
            continue
        j = pos[i]
        pts = block_points(blocks, i, np.asarray(m.steps_per_mm))
        steps = np.diff(pts, axis=0)
        rates = tick_rates(row["ticks"], row["f_entry"], row["f_peak"], row["f_exit"], row["f_min"],
                           row["up"], row["down"], row["law"])
        periods = np.asarray(timer_period(rates, timer_clock_hz=m.timer_clock_hz, prescaler=m.prescaler))
        clock += int(((periods + 1) * (m.prescaler + 1)).sum())
        entry.update({
            "start_steps": blocks.start_steps[i].tolist(),
            "end_steps": blocks.end_steps[i].tolist(),
            "dir_bits": int(((blocks.end_steps[i] - blocks.start_steps[i]) < 0) @ [1, 2, 4]),
            "ticks": row["ticks"],
            "steps_per_axis": np.abs(steps).sum(axis=0).tolist(),
            "length_mm": float(blocks.length_mm[i]),
            "super_block": int(p.lookahead.super_block[j]),
            "entry_mm_s": float(prof.entry_mm_s[j]),
            "peak_mm_s": float(prof.peak_mm_s[j]),
            "exit_mm_s": float(prof.exit_mm_s[j]),
            "f_entry": row["f_entry"], "f_peak": row["f_peak"], "f_exit": row["f_exit"],
            "f_min": row["f_min"], "up": row["up"], "down": row["down"], "f_feed": row["f_feed"],
            "laser": row["laser"], "power_mw": row["power_mw"],
            "period_entry": int(periods[0]), "period_peak": int(periods.min()),
            "period_exit": int(periods[-1]),
            "cycles_end": clock,
            "tick_steps": [[int(a) for a in s] for s in steps],
            "tick_periods": periods.tolist(),
            "tick_power_mw": _floats(tick_power_mw(row, rates, max_power_mw=m.laser_max_power_mw)),
        })
        out_blocks.append(entry)
    s = p.summary()
    return {
        "schema": SCHEMA,
        "name": name,
        "description": case["description"],
        "generated_by": "tests/vectors/motion/generate.py (labkit.motion reference)",
        # the motion fields only: grbl_settings are what a sender reads from the controller,
        # rest_at_zero is false in every vector (FIRMWARE_REST)
        "machine": {k: v for k, v in m.to_dict().items()
                    if k not in ("description", "grbl_settings", "rest_at_zero")},
        "planner": case["planner"], "law": p.law, "buffer_blocks": p.lookahead.buffer_blocks,
        "dialect": "grbl",
        "gcode": case["gcode"],
        "blocks": out_blocks,
        "summary": {"blocks": s.blocks, "super_blocks": s.super_blocks, "job_time_s": s.job_time_s,
                    "ticks": int(sum(b.get("ticks", 0) for b in out_blocks)), "cycles_total": clock,
                    "final_steps": out_blocks[-1].get("end_steps") if out_blocks else None},
    }


def _diff(a, b, path="$"):
    """First difference between two JSON values (floats to 1e-12 relative), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return f"{path}: keys differ {sorted(set(a) ^ set(b))}"
        for k in a:
            d = _diff(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = _diff(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12):
            return None
        return f"{path}: {a!r} != {b!r}"
    return None if a == b else f"{path}: {a!r} != {b!r}"


def check(name: str) -> str | None:
    """Compare the stored vector with a fresh one; the first difference, or None."""
    path = HERE / f"{name}.json"
    if not path.exists():
        return f"{path} is missing (run with --refresh)"
    return _diff(json.loads(path.read_text()), json.loads(dumps(make_vector(name))))


def dumps(obj, indent: int = 0) -> str:
    """JSON with one key per line but every list of numbers (or of short number lists) on one line."""
    pad = " " * indent
    if isinstance(obj, dict):
        items = [f'{pad} {json.dumps(k)}: {dumps(v, indent + 1).lstrip()}' for k, v in obj.items()]
        return pad + "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, list) and obj and all(isinstance(x, dict) for x in obj):
        return pad + "[\n" + ",\n".join(dumps(x, indent + 1) for x in obj) + "\n" + pad + "]"
    return pad + json.dumps(obj, separators=(",", ":"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refresh", action="store_true", help="rewrite every vector from the reference")
    args = ap.parse_args(argv)
    bad = 0
    for name in CASES:
        if args.refresh:
            (HERE / f"{name}.json").write_text(dumps(make_vector(name)) + "\n")
            print(f"wrote {name}.json")
        else:
            d = check(name)
            print(f"{name}: {'ok' if d is None else d}")
            bad += d is not None
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
