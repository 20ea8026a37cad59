"""Previews of big jobs (issue 9 work bombs, issue 11 §2): an image, within a time ceiling."""

from __future__ import annotations


def test_preview_of_a_200000_move_job_is_an_image_in_bounded_time(tmp_path, run_labkit):
    job = tmp_path / "raster.gcode"
    with open(job, "w") as fh:
        fh.write("G21 G90 M3 S500 F3000\n")
        for k in range(100_000):
            fh.write(f"G1 X{50 * (k % 2 == 0)} Y{k * 0.01:.2f}\nG0 X{50 * (k % 2 == 0)} Y{(k + 1) * 0.01:.2f}\n")
    out = tmp_path / "p.png"
    r = run_labkit(["preview", job, "-o", out], time_s=60, memory_mb=1500)
    assert r.code == 0 and out.stat().st_size > 10_000
