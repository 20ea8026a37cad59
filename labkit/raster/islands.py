"""Split a mask into 4-connected islands ([LaserApp] §3.4.1, "Image Segmentation").

The seed grows each island from a seed pixel through its up, down, left and
right neighbours; the same partition is scikit-image's connected-component
labelling with ``connectivity=1``.
"""

from __future__ import annotations

import numpy as np

from labkit.raster._border import check_mask

__all__ = ["label_islands", "island_sizes"]


def label_islands(mask) -> tuple[np.ndarray, int]:
    """Label the 4-connected islands of marked pixels.

    Parameters
    ----------
    mask : ndarray of bool, 2-D
        True = marked (to burn).

    Returns
    -------
    labels : ndarray of int32
        0 for unmarked pixels, 1 … n for the islands in row-major order of
        their first pixel.
    n : int
        Number of islands.

    Examples
    --------
    >>> m = np.array([[1, 1, 0], [0, 0, 1], [1, 0, 1]], dtype=bool)
    >>> labels, n = label_islands(m)
    >>> n, labels.tolist()
    (3, [[1, 1, 0], [0, 0, 2], [3, 0, 2]])
    """
    from skimage.measure import label

    m = check_mask(mask)
    labels, n = label(m, connectivity=1, return_num=True)
    return labels.astype(np.int32, copy=False), int(n)


def island_sizes(labels, n: int) -> np.ndarray:
    """Pixel count of each island 1 … n (index 0 of the result is island 1).

    Examples
    --------
    >>> island_sizes(np.array([[1, 1, 0], [0, 2, 2], [0, 0, 2]]), 2).tolist()
    [2, 3]
    """
    return np.bincount(np.asarray(labels).ravel(), minlength=n + 1)[1:]
