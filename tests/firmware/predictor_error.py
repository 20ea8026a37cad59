"""The stall predictor's error on the jobs of ``test_paced_link.py``, for the closing note of issue 30.

Not a test (about 10 minutes on 2 cores): for each job, the stall-free feed the predictor
gives (F*, ``stall_free_feed`` with stream.py's byte counts) and the one the paced firmware
simulator shows, found by streaming with stream.py (``--expect``) between 0.95 F* and 1.05 F*
(the bracket the test checks) and halving to 0.5 %; a stream "starves" when a starvation is
logged that stream.py's once-a-second ``?`` cannot explain (``poll_shadows``). For every
stream: whether each simulated starvation was predicted at its line.

Run from the worktree root: .venv/bin/python tests/firmware/predictor_error.py
"""
from __future__ import annotations

import contextlib
import io
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import test_paced_link as T  # noqa: E402
from labkit.motion.stall import predict_stalls, stall_free_feed, with_feed  # noqa: E402


def main():
    subprocess.run(["make", "-C", str(T.REAL_SENDERS.FW), "sim"], check=True, capture_output=True)
    sim = str(T.REAL_SENDERS.SIM)
    print(f"{'job':38s} {'F* predicted':>12s} {'F* simulated':>16s} {'error':>7s} {'streams':>7s} "
          f"{'simulated stalls all predicted':>30s}")
    for job in T.JOBS:
        name, make, baud = job[:3]
        with tempfile.TemporaryDirectory() as folder:
            tmp = Path(folder)
            with contextlib.redirect_stdout(io.StringIO()):      # img2gcode's and svg2gcode's summaries
                text = make(tmp)
            machine = T.job_machine(job)
            f_star = stall_free_feed(text, machine, line_bytes=T.stream_py_bytes, rel_tol=0.005, rows=False).feed_mm_min
            runs, all_predicted = {}, True

            def starves(feed):
                nonlocal all_predicted
                program = with_feed(text, feed)
                simulated, seconds = T.stream_job(sim, program, machine, tmp)
                predicted = predict_stalls(program, machine, line_bytes=T.stream_py_bytes(program)).stalls
                shadows, missed = T.poll_shadows(simulated, predicted, baud, seconds)
                all_predicted &= not missed
                runs[feed] = bool([s for s in simulated if s not in shadows])
                return runs[feed]

            lo, hi = 0.95 * f_star, 1.05 * f_star
            if starves(lo) or not starves(hi):
                print(f"{name:38s} {f_star:12.1f} {'outside ±5 %':>16s}")
                continue
            while hi - lo > 0.005 * hi:
                mid = 0.5 * (lo + hi)
                if starves(mid):
                    hi = mid
                else:
                    lo = mid
            print(f"{name:38s} {f_star:12.1f} {f'{lo:.1f}-{hi:.1f}':>16s} {f_star / (0.5 * (lo + hi)) - 1:+7.1%} "
                  f"{len(runs):7d} {str(all_predicted):>30s}", flush=True)


if __name__ == "__main__":
    main()
