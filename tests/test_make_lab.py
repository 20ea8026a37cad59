"""`make lab` starts JupyterLab on the index notebook, with extra arguments passed through."""

import os
import secrets
import shutil
import signal
import socket
import subprocess
import time
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.skipif(shutil.which("make") is None, reason="GNU make is not installed")
def test_make_lab_serves_the_index_with_pass_through_arguments(tmp_path):
    if not (ROOT / ".venv" / ".installed").exists():
        pytest.skip("the environment is not set up by make (running outside `make test`)")
    port, token = _free_port(), secrets.token_hex(8)
    env = dict(os.environ, JUPYTER_RUNTIME_DIR=str(tmp_path / "rt"),
               JUPYTERLAB_WORKSPACES_DIR=str(tmp_path / "ws"))
    args = f"--no-browser --port {port} --ip 127.0.0.1 --IdentityProvider.token={token}"
    log_path = tmp_path / "make-lab.log"
    served = False
    with open(log_path, "w") as log:
        proc = subprocess.Popen(["make", "--no-print-directory", "lab", f"LAB_ARGS={args}"], cwd=ROOT,
                                env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            deadline = time.time() + 180
            url = f"http://127.0.0.1:{port}/api/contents/notebooks/00-index.ipynb?content=0&token={token}"
            while proc.poll() is None and time.time() < deadline:
                try:
                    with urllib.request.urlopen(url, timeout=2) as r:
                        served = r.status == 200
                    break
                except OSError:
                    time.sleep(0.5)
            if served:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/lab?token={token}", timeout=5) as r:
                    page = r.read()
        finally:
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    out = log_path.read_text()
    assert served, f"make lab did not serve on port {port}:\n{out[-2000:]}"
    assert b"JupyterLab" in page
    # The command make ran: the index notebook plus the arguments we passed through.
    assert "notebooks/00-index.ipynb" in out and f"--port {port}" in out
