"""Bitmaps embedded in an SVG (<image> with a data: URI or a file beside it) engraved by a job at
their placed size and position, worked by hand on a 40 mm page (y flipped)."""

import base64
import io

import numpy as np
import pytest
from PIL import Image

from labkit.errors import InputError
from labkit.jobfile import compose_job, read_job, svg_images


def _png(pixels) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="PNG")
    return buf.getvalue()


@pytest.fixture
def folder(tmp_path):
    black = np.zeros((10, 20), np.uint8)                       # 20 × 10 px, all black (made here)
    half = np.full((10, 20), 255, np.uint8)
    half[:, :10] = 0                                            # the left half black
    (tmp_path / "half.png").write_bytes(_png(half))
    uri = "data:image/png;base64," + base64.b64encode(_png(black)).decode()
    (tmp_path / "art.svg").write_text(f"""<svg xmlns="http://www.w3.org/2000/svg"
  xmlns:xlink="http://www.w3.org/1999/xlink" width="60mm" height="40mm" viewBox="0 0 60 40">
<image id="inline" x="10" y="5" width="20" height="10" xlink:href="{uri}"/>
<g transform="translate(0 20)"><image id="linked" x="30" y="0" width="10" height="10" href="half.png"
   preserveAspectRatio="none"/></g>
<image id="fitted" x="0" y="30" width="20" height="20" href="half.png"/>
</svg>""")                                                       # written by hand
    return tmp_path


def test_images_are_placed_as_drawn(folder):
    placed = {p.name: p for p in svg_images(folder / "art.svg")}
    a = placed["image#inline"]
    assert (a.x_mm, a.y_mm, a.width_mm, a.height_mm) == pytest.approx((10, 25, 20, 10), abs=1e-4)
    b = placed["image#linked"]                          # stretched to its 10 × 10 box, y 20…30 after the group
    assert (b.x_mm, b.y_mm, b.width_mm, b.height_mm) == pytest.approx((30, 10, 10, 10), abs=1e-4)
    c = placed["image#fitted"]                                   # 2:1 fitted into 20 × 20, centred: y 35…45 in SVG
    assert (c.x_mm, c.y_mm, c.width_mm, c.height_mm) == pytest.approx((0, -5, 20, 10), abs=1e-4)


def test_a_job_engraves_them_where_they_are(folder):
    (folder / "job.toml").write_text('format = "labkit-job"\nversion = 1\nmachine = "cbr40-laser"\n'
                                     '[[layer]]\nsource = "art.svg"\noperation = "image"\n'
                                     'select = ["inline", "linked"]\nmode = "zigzag"\npower_mw = 500.0\n'
                                     'speed_mm_min = 1000.0\nline_interval_mm = 0.5\n')
    m = compose_job(read_job(folder / "job.toml")).moves
    on = m.laser_on
    xs = np.c_[m.start[on, 0], m.end[on, 0]]
    ys = m.end[on, 1]
    inline = ys > 24
    # the black 20 × 10 mm bitmap: lines x 10…30 at y 25.25 … 34.75 every 0.5 mm
    assert xs[inline].min() == pytest.approx(10) and xs[inline].max() == pytest.approx(30)
    assert np.allclose(sorted(set(np.round(ys[inline], 6))), 25.25 + 0.5 * np.arange(20))
    # the linked one's black half, stretched into 10 × 10 mm: the burn covers x 30…35, y 10…20 (the
    # engraver may scan it in columns: then the line centres lie half a pitch inside on x)
    linked = ~inline
    y_all = np.c_[m.start[on, 1], m.end[on, 1]][linked]
    half_pitch = 0.25 + 1e-3                                         # and the reader's 1e-5 mm of rounding
    assert xs[linked].min() == pytest.approx(30, abs=half_pitch)
    assert xs[linked].max() == pytest.approx(35, abs=half_pitch)
    assert y_all.min() == pytest.approx(10, abs=half_pitch) and y_all.max() == pytest.approx(20, abs=half_pitch)
    burned = float(np.hypot(*(m.end[on] - m.start[on])[:, :2][linked].T).sum())
    assert burned == pytest.approx(5 * 10 / 0.5, rel=0.06)          # 50 mm² at 0.5 mm pitch
    assert m.start[0].tolist() == [0.0, 0.0, 0.0]


def test_bad_embedded_images(folder):
    svg = (folder / "art.svg").read_text()
    (folder / "bad.svg").write_text(svg.replace('href="half.png"\n   preserveAspectRatio', 'href="gone.png"\n'
                                                '   preserveAspectRatio'))
    with pytest.raises(InputError, match=r"image#linked links 'gone.png', which is not a file"):
        svg_images(folder / "bad.svg")
    (folder / "bad.svg").write_text(svg.replace('<g transform="translate(0 20)">', '<g transform="rotate(10)">'))
    with pytest.raises(InputError, match="image#linked is rotated or skewed"):
        svg_images(folder / "bad.svg")
    (folder / "bad.svg").write_text(svg.replace('base64,', 'base64,AAAA'))
    with pytest.raises(InputError, match="image#inline: .*not an image file"):
        svg_images(folder / "bad.svg")
