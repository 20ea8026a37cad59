"""svg2gcode --images: the bitmaps an SVG embeds engraved where it places them, before the cuts,
through the code a job's image layer uses (labkit.jobfile.engrave_images); worked by hand on a
40 mm page (y flipped). Without --images they are named, never burned silently."""

from __future__ import annotations

import base64
import io

import numpy as np
import pytest
from PIL import Image

from labkit.cli import main
from labkit.gcode import parse


@pytest.fixture
def art(tmp_path):
    buf = io.BytesIO()
    Image.fromarray(np.zeros((10, 20), np.uint8)).save(buf, format="PNG")      # 20 × 10 px, black
    uri = "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()
    path = tmp_path / "art.svg"
    path.write_text(f"""<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"
  width="60mm" height="40mm" viewBox="0 0 60 40">
<image id="photo" x="10" y="5" width="20" height="10" xlink:href="{uri}"/>
<rect id="outline" x="2" y="2" width="56" height="36" fill="none" stroke="#000"/>
</svg>""")                                                                     # written by hand
    return path


def test_images_are_engraved_where_placed_before_the_cut(art, tmp_path, capsys):
    out = tmp_path / "art.gcode"
    assert main(["svg2gcode", str(art), "-o", str(out), "--images", "zigzag", "--fill-spacing", "0.5",
                 "--image-power", "300", "--power", "900"]) == 0
    assert "image#photo" not in capsys.readouterr().err
    m = parse(out.read_text())
    on = m.laser_on
    image = on & (m.s_word == 300)
    cut = on & (m.s_word == 900)
    # the black 20 × 10 mm bitmap at SVG (10, 5): lines x 10…30 at y 25.25 … 34.75 every 0.5 mm
    xs = np.c_[m.start[image, 0], m.end[image, 0]]
    assert xs.min() == pytest.approx(10) and xs.max() == pytest.approx(30)
    assert np.allclose(sorted(set(np.round(m.end[image, 1], 6))), 25.25 + 0.5 * np.arange(20))
    # then the outline 2…58 × 2…38, after every image line
    assert np.flatnonzero(image).max() < np.flatnonzero(cut).min()
    ends = np.vstack([m.start[cut, :2], m.end[cut, :2]])
    assert ends.min(axis=0) == pytest.approx([2, 2]) and ends.max(axis=0) == pytest.approx([58, 38])


def test_without_images_the_bitmap_is_named_not_burned(art, tmp_path, capsys):
    out = tmp_path / "art.gcode"
    assert main(["svg2gcode", str(art), "-o", str(out), "--power", "900"]) == 0
    assert "not cut: 1 element(s) that are not vector shapes: image#photo" in capsys.readouterr().err
    m = parse(out.read_text())
    assert set(m.s_word[m.laser_on]) == {900.0}
    assert m.bounds(m.laser_on)[0][:2].tolist() == pytest.approx([2, 2])


def test_images_asked_of_an_svg_without_any(tmp_path, capsys):
    path = tmp_path / "plain.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">'
                    '<rect x="2" y="2" width="10" height="10" fill="none" stroke="#000"/></svg>')
    assert main(["svg2gcode", str(path), "-o", str(tmp_path / "o.gcode"), "--images", "gray"]) == 1
    assert "--images gray: the SVG embeds no bitmap" in capsys.readouterr().err
    assert not (tmp_path / "o.gcode").exists()


def test_an_unknown_image_mode_is_refused_with_the_modes(tmp_path, capsys):
    """--images is checked against img2gcode's modes (raster.engrave.MODES) when it is given:
    a usage error naming them, nothing written."""
    from labkit.raster.engrave import MODES

    path = tmp_path / "plain.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">'
                    '<rect x="2" y="2" width="10" height="10" fill="none" stroke="#000"/></svg>')
    with pytest.raises(SystemExit) as stop:
        main(["svg2gcode", str(path), "-o", str(tmp_path / "o.gcode"), "--images", "grey"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--images: invalid choice: 'grey'" in err and all(m in err for m in MODES)
    assert not (tmp_path / "o.gcode").exists()


def test_svg2gcode_without_images_does_not_import_the_raster_package(tmp_path):
    """The raster package is loaded only for --images (a fresh process, as a user runs it)."""
    import subprocess
    import sys

    path = tmp_path / "plain.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">'
                    '<rect x="2" y="2" width="10" height="10" fill="none" stroke="#000"/></svg>')
    code = ("import sys; from labkit.cli import main; "
            f"rc = main(['svg2gcode', {str(path)!r}, '-o', {str(tmp_path / 'o.gcode')!r}]); "
            "print(rc, any(m.startswith('labkit.raster') for m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split()[-2:] == ["0", "False"]
