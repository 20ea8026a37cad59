"""Regenerate the phone-photo, transparency and pixel-density samples of this folder
(issue 27; run from the repository root: ``.venv/bin/python data/images/make_real_world.py``).

Each file is written by Pillow the way cameras and editors write them: the EXIF
orientation tag in a JPEG and a WebP, each kind of PNG transparency (alpha channel,
``tRNS`` colour key on RGB, 8-bit and 16-bit gray, palette transparency), JFIF and PNG
``pHYs`` with different x and y densities. Deterministic: no randomness. The photo is
scikit-image's ``astronaut`` (NASA, public domain), cropped to 500 × 450 px at 72 dpi.
"""

from pathlib import Path

import numpy as np
from PIL import Image

HERE = Path(__file__).parent
ORIENTATION = 0x0112


def marked(rows=40, cols=60):
    """A landscape card as the camera stores it: a black block in the top-left corner,
    a gray bar along the top edge (which way is up), white elsewhere."""
    img = np.full((rows, cols, 3), 255, np.uint8)
    img[:4, 12:] = 128
    img[:10, :10] = 0
    return img


def _exif(orientation):
    exif = Image.Exif()
    exif[ORIENTATION] = orientation
    return exif.tobytes()


#: Colour stored under the transparent half of the transparency samples: dark, so any
#: mode that ignored the transparency would burn it.
KEY_RGB = (60, 60, 60)
KEY_GRAY = 60
KEY_GRAY16 = 60 * 257


def transparency_card(rows=30, cols=40):
    """(opaque picture, blank mask): left 16 columns transparent; on the right, on white,
    a black square and a mid-gray square (every mode burns something there)."""
    img = np.full((rows, cols), 255, np.uint8)
    img[4:14, 20:30] = 0
    img[17:27, 24:36] = 128
    blank = np.zeros((rows, cols), bool)
    blank[:, :16] = True
    return img, blank


def main():
    card = marked()
    Image.fromarray(card).save(HERE / "phone_orientation_3.jpg", quality=95, exif=_exif(3))
    Image.fromarray(card).save(HERE / "phone_orientation_6.jpg", quality=95, exif=_exif(6))
    Image.fromarray(card).save(HERE / "phone_orientation_8.webp", lossless=True, exif=_exif(8))

    gray, blank = transparency_card()
    rgb = np.repeat(gray[:, :, None], 3, axis=2)
    stored = np.where(blank[:, :, None], np.array(KEY_RGB, np.uint8), rgb)
    Image.fromarray(stored).save(HERE / "transparent_rgb_key.png", transparency=KEY_RGB)
    rgba = np.dstack([np.where(blank[:, :, None], 0, rgb), np.where(blank, 0, 255)]).astype(np.uint8)
    Image.fromarray(rgba).save(HERE / "transparent_alpha.png")
    Image.fromarray(np.where(blank, KEY_GRAY, gray).astype(np.uint8)).save(
        HERE / "transparent_gray_key.png", transparency=KEY_GRAY)
    gray16 = np.where(blank, KEY_GRAY16, gray.astype(np.uint16) * 257).astype(np.uint16)
    Image.fromarray(gray16).save(HERE / "transparent_gray16_key.png", transparency=KEY_GRAY16)
    palette = Image.fromarray(stored).quantize(colors=4, method=Image.Quantize.MEDIANCUT)
    index = palette.getpixel((0, 0))                  # the stored dark colour's palette entry
    palette.save(HERE / "transparent_palette.png", transparency=index)

    density = np.full((40, 60), 255, np.uint8)
    density[10:30, 20:40] = 0                           # a square as the file stores it
    Image.fromarray(density).save(HERE / "density_200x100.jpg", quality=95, dpi=(200, 100))
    Image.fromarray(density).save(HERE / "density_200x100.png", dpi=(200, 100))

    from skimage import data

    Image.fromarray(data.astronaut()[20:470, 6:506]).save(HERE / "photo_500x450_72dpi.jpg", quality=90,
                                                          dpi=(72, 72))


if __name__ == "__main__":
    main()
