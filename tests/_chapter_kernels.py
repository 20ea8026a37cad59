"""Record which compiled kernels the chapters and the commands call, with which argument types.

Each chapter is executed in memory (nothing is written back) in a Jupyter kernel with
``LABKIT_JIT=compiled``, so every kernel a cell reaches is compiled whatever the size of its
input; one cell appended at the end prints :func:`labkit._jit.compiled_signatures`. Each
command of :data:`COMMANDS` runs the same way in a process of its own. The union is written
to ``labkit/_warm_kernels.json``: what ``make lab`` compiles (:func:`labkit._jit.warm`),
and what ``tests/test_kernel_cache.py`` checks is in the cache afterwards.

Run again after a chapter or a command starts using another kernel or other argument types
(minutes per chapter when the kernels compile, much less with a warm cache)::

    .venv/bin/python tests/_chapter_kernels.py                 # everything
    .venv/bin/python tests/_chapter_kernels.py notebooks/03-*.ipynb   # update one chapter
    .venv/bin/python tests/_chapter_kernels.py --commands             # update the commands
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "labkit" / "_warm_kernels.json"
DATA = ROOT / "data"
CNCJS = DATA / "gcode" / "cncjs"

#: The commands whose kernels ``make lab`` warms: each as a student types it (real files
#: made by real tools: cncjs's examples, ezdxf's and OpenSCAD's DXFs).
COMMANDS = [
    ["check", CNCJS / "jsdc-laser.gcode"],
    ["info", CNCJS / "Circle_Diamond_Square_Calibration.gcode", "--lenient"],
    ["preview", CNCJS / "tball-engrave-laser.gcode", "-o", "{tmp}/p.png"],
    ["plan", CNCJS / "Circle_Diamond_Square_Calibration.gcode", "--lenient"],
    ["plan", CNCJS / "jsdc-laser.gcode", "--machine", "grbl-diode", "--planner", "junction"],
    ["steps", CNCJS / "jsdc-laser.gcode", "-o", "{tmp}/s.txt"],
    ["stream", CNCJS / "jsdc-laser.gcode", "--no-record"],
    ["svg2gcode", CNCJS / "jsdc.svg", "-o", "{tmp}/a.gcode"],
    ["svg2gcode", CNCJS / "jsdc.svg", "-o", "{tmp}/b.gcode", "--fit", "biarc"],
    ["svg2gcode", CNCJS / "jsdc.svg", "-o", "{tmp}/c.gcode", "--arcs"],
    ["dxf2gcode", DATA / "dxf" / "parts_mm.dxf", "-o", "{tmp}/d.gcode", "--force"],
] + [
    ["img2gcode", CNCJS / "jsdc.png", "-o", "{tmp}/" + mode + ".gcode", "--mode", mode, "--force"]
    for mode in ("zigzag", "spiral", "edges", "gray", "dither")
]

# Printed by the appended cell (and after each command): what this process compiled.
_REPORT = """
import json as _json, labkit._jit as _lkjit
print("LABKIT-KERNELS " + _json.dumps(_lkjit.compiled_signatures()))
"""


def _found(text: str) -> dict[str, dict[str, str]]:
    for line in text.splitlines():
        if line.startswith("LABKIT-KERNELS "):
            return json.loads(line.split(" ", 1)[1])
    raise RuntimeError("the report printed nothing")


def record_chapter(notebook: Path, timeout_s: float = 1800) -> dict[str, dict[str, str]]:
    """Run one chapter with every kernel compiled; the kernels it compiled and their signatures."""
    import nbclient
    import nbformat

    nb = nbformat.read(notebook, as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(_REPORT))
    os.environ["LABKIT_JIT"] = "compiled"            # the kernel inherits this process's environment
    client = nbclient.NotebookClient(nb, timeout=timeout_s, kernel_name="python3",
                                     resources={"metadata": {"path": str(notebook.parent)}})
    client.execute()
    return _found("".join(o.get("text", "") for o in nb.cells[-1].get("outputs", [])))


def record_command(argv: list, timeout_s: float = 1800) -> dict[str, dict[str, str]]:
    """Run one command in a process of its own with every kernel compiled; what it compiled."""
    with tempfile.TemporaryDirectory() as tmp:
        args = [str(a).format(tmp=tmp) for a in argv]
        code = ("import sys\nfrom labkit.cli import main\n"
                f"code = main({args!r})\n" + _REPORT + "sys.exit(code)\n")
        done = subprocess.run([sys.executable, "-c", code], cwd=tmp, capture_output=True, text=True,
                              env=dict(os.environ, LABKIT_JIT="compiled"), timeout=timeout_s)
    if done.returncode != 0:
        raise RuntimeError(f"labkit {' '.join(args)}: {done.stderr.strip()[-300:]}")
    return _found(done.stdout)


def _write(table: dict) -> None:
    table["by_source"] = dict(sorted(table["by_source"].items()))
    table["signatures"] = {k: dict(sorted(v.items())) for k, v in sorted(table["signatures"].items())}
    table["made_by"] = ("tests/_chapter_kernels.py: every chapter and command run with "
                        "LABKIT_JIT=compiled; the numba signatures each kernel was compiled for")
    OUT.write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")


def main(paths: list[str]) -> int:
    table = json.loads(OUT.read_text()) if OUT.exists() and paths else {}
    table.setdefault("by_source", {})
    table.setdefault("signatures", {})
    commands = [("labkit " + " ".join(str(a).replace(str(ROOT) + "/", "") for a in argv), argv)
                for argv in COMMANDS]
    if paths == ["--commands"]:
        jobs = commands
    elif paths:
        jobs = [(f"notebooks/{Path(p).name}", Path(p)) for p in paths]
    else:
        jobs = [(f"notebooks/{nb.name}", nb)
                for nb in sorted((ROOT / "notebooks").glob("[0-9][0-9]-*.ipynb"))]
        jobs += commands
    failed = []
    for name, what in jobs:
        print(f"{name} ...", flush=True)
        try:
            found = record_chapter(what.resolve()) if isinstance(what, Path) else record_command(what)
        except Exception as exc:                  # noqa: BLE001 (reported; the others still run)
            failed.append(f"{name}: {type(exc).__name__}: {str(exc)[:300]}")
            print(failed[-1], flush=True)
            continue
        table["by_source"][name] = {k: sorted(v) for k, v in sorted(found.items())}
        # the union, made again from every source: a signature no source calls now goes
        known = table["signatures"]
        for kernel, sigs in found.items():
            known.setdefault(kernel, {}).update(sigs)
        table["signatures"] = {}
        for kernels in table["by_source"].values():
            for kernel, reprs in kernels.items():
                for text in reprs:
                    table["signatures"].setdefault(kernel, {})[text] = known[kernel][text]
        _write(table)
    print("\n".join(failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
