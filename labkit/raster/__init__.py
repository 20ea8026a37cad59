"""Raster images → laser moves ([LaserApp] §2.5, §3.4.1).

color       gray conversion (seed, Rec. 601, Rec. 709), threshold, invert, gamma
filters     3×3 blur and sharpen
edges       SXOR, Roberts, Sobel, Prewitt (kernel and pseudo-convolution); Canny to compare
resample    one pixel = one beam diameter, with the size error in mm
islands     4-connected segmentation
pathing     zig-zag runs, spiral corner walk, greedy segment connection (O(n²) and indexed)
diffusion   error diffusion (Floyd–Steinberg, Atkinson, Jarvis–Judice–Ninke, Stucki)
engrave     image → Moves for every mode, with the seed's report figures; raster_program: the G-code text
coverage    Moves → burned pixels (the independent check of every path)
io          image files as a viewer shows them (EXIF orientation, transparency, pixel aspect), with their dpi
"""

from labkit.raster.color import (GRAY_WEIGHTS, SEED_DEPTHS, adjust_gamma, depth_to_level, invert,
                                 threshold, threshold_depths, to_gray)
from labkit.raster.edges import (OPERATORS, SKIMAGE_FACTOR, canny, detect_edges, edge_angle, gradients,
                                 max_magnitude, prewitt, roberts, sobel, sxor)
from labkit.raster.filters import BLUR_KERNEL, BOX_KERNEL, SHARPEN_KERNEL, blur, convolve3x3, sharpen
from labkit.raster.io import RasterImage, read_image
from labkit.raster.islands import island_sizes, label_islands
from labkit.raster.resample import Resampled, physical_size_mm, resample_to_beam

__all__ = [
    "GRAY_WEIGHTS", "SEED_DEPTHS", "to_gray", "threshold", "depth_to_level", "threshold_depths",
    "invert", "adjust_gamma",
    "SHARPEN_KERNEL", "BLUR_KERNEL", "BOX_KERNEL", "convolve3x3", "blur", "sharpen",
    "OPERATORS", "SKIMAGE_FACTOR", "sxor", "roberts", "sobel", "prewitt", "gradients", "edge_angle",
    "max_magnitude", "detect_edges", "canny",
    "Resampled", "physical_size_mm", "resample_to_beam",
    "label_islands", "island_sizes",
    "RasterImage", "read_image",
]

from labkit.raster.coverage import burn_map  # noqa: E402
from labkit.raster.diffusion import DIFFUSION, dither  # noqa: E402
from labkit.raster.engrave import (MODES, RasterJob, RasterReport, gray_job, image_to_job,  # noqa: E402
                                   mask_job, power_map, raster_program, segments_to_moves, summarize)
from labkit.raster.pathing import (Connection, Segments, choose_axis, connect, scan_order,  # noqa: E402
                                   spiral_segments, zigzag_segments)

__all__ += [
    "Segments", "Connection", "zigzag_segments", "spiral_segments", "connect", "scan_order", "choose_axis",
    "DIFFUSION", "dither", "burn_map",
    "MODES", "RasterJob", "RasterReport", "segments_to_moves", "mask_job", "gray_job", "power_map",
    "image_to_job", "summarize", "raster_program",
]
