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


def test_preview_of_ten_million_lines_is_refused_before_parsing(tmp_path, run_labkit):
    """10 M lines held as moves peaked at 4.3 GB: the line count is checked first."""
    job = tmp_path / "huge.gcode"
    with open(job, "wb") as f:
        f.write(b"G1 X1 Y1 F600\nG1 X0 Y0\n" * 5_000_000)
    r = run_labkit(["preview", job, "-o", tmp_path / "p.png"], time_s=60, memory_mb=600)
    assert r.code == 1 and not (tmp_path / "p.png").exists()
    assert "too much work: 10,000,001 preview lines (budget 2,000,000) from drawing all of" in r.stderr
