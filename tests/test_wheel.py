"""labkit installs as a wheel: runtime data (machine descriptions, the status table) ship
inside it, so a command works from any directory of a fresh environment."""

from __future__ import annotations

import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_wheel_installs_and_plans_with_a_shipped_machine(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps",
                    "-w", str(wheels), str(ROOT)], check=True, timeout=300)
    wheel = next(wheels.glob("labkit-*.whl"))
    # A fresh environment that reuses this one's third-party packages (no downloads)
    # through a plain path entry, after its own site-packages: the wheel's labkit wins,
    # and this environment's editable labkit (a .pth hook) is never activated there.
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    ours = next(p for p in sys.path if p.endswith("site-packages") and Path(p, "numpy").is_dir())
    Path(site, "zz_reuse_test_env.pth").write_text(ours + "\n")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", site,
                    str(wheel)], check=True, timeout=300)
    job = tmp_path / "elsewhere" / "job.gcode"
    job.parent.mkdir()
    job.write_text("G21 G90\nM3 S500\nG1 X10 Y5 F600\nG2 X20 Y5 I5 J0\nM5\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    r = subprocess.run([str(python), "-c",
                        "import labkit, sys; from labkit.cli import main; "
                        "print(labkit.__file__, file=sys.stderr); sys.exit(main(sys.argv[1:]))",
                        "plan", "--machine", "grbl-diode", "job.gcode"],
                       cwd=job.parent, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert str(site) in r.stderr and str(ROOT) not in r.stderr.splitlines()[0]
    assert "machine                     grbl-diode" in r.stdout
    assert "job time" in r.stdout
