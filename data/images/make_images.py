"""Regenerate the images in this folder (run from the repository root:
``.venv/bin/python data/images/make_images.py``). Deterministic: no randomness."""

from pathlib import Path

import numpy as np
from PIL import Image

HERE = Path(__file__).parent


def waves(rows=250, cols=400):
    """Thin wavy black bands on white: a diffuse distribution of pixels, like seed 000's image B."""
    y, x = np.mgrid[0:rows, 0:cols].astype(float)
    phase = x / 9.0 + 2.5 * np.sin(y / 23.0) + 1.5 * np.sin(x / 61.0)
    black = np.sin(phase) > 0.55
    return np.where(black, 0, 255).astype(np.uint8)


HEART = """
..XX...XX..
.XXXX.XXXX.
XXXXXXXXXXX
XXXXXXXXXXX
XXXXXXXXXXX
.XXXXXXXXX.
..XXXXXXX..
...XXXXX...
....XXX....
.....X.....
"""


def heart():
    """Pixel art (11 × 10), for nearest-neighbour resampling."""
    rows = [r for r in HEART.strip().splitlines()]
    return np.array([[0 if ch == "X" else 255 for ch in r] for r in rows], dtype=np.uint8)


def gray_card(rows=120, cols=256):
    """A test card: a 0…255 ramp, eight flat steps and a dark disc with a soft edge."""
    img = np.full((rows, cols), 255.0)
    img[:40] = np.linspace(0, 255, cols)[None, :]
    steps = np.repeat(np.linspace(0, 255, 8), cols // 8)
    img[40:80] = steps[None, :]
    y, x = np.mgrid[80:rows, 0:cols]
    r = np.hypot(x - cols / 2, (y - 100) * 1.0)
    img[80:] = np.clip((r - 10) * 20, 0, 255)
    return img.round().astype(np.uint8)


if __name__ == "__main__":
    Image.fromarray(waves()).save(HERE / "waves.png", dpi=(254, 254))
    Image.fromarray(heart()).save(HERE / "heart.png")
    Image.fromarray(gray_card()).save(HERE / "gray_card.png", dpi=(254, 254))
