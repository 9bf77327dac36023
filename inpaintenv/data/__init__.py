"""Data sources: real KITTI depth and the built-in synthetic streets, plus splits."""

from .base import (
    ArrayDataset, ConcatDataset, DepthDataset, Subset, as_dataset, select_drives, split_by_drive, subset,
)
from .cache import CachedDataset, StaleCacheError, estimate_cache_bytes
from .io import DepthFormatError, read_depth_png, write_depth_png
from .kitti import KITTI_ROOT_ENV, KITTI_URL, KittiDepth, bottom_center_crop, png_header
from .sources import open_source
from .synthetic import SyntheticStreets

__all__ = [
    "ArrayDataset",
    "CachedDataset",
    "ConcatDataset",
    "DepthDataset",
    "DepthFormatError",
    "KITTI_ROOT_ENV",
    "KITTI_URL",
    "KittiDepth",
    "Subset",
    "StaleCacheError",
    "SyntheticStreets",
    "as_dataset",
    "bottom_center_crop",
    "estimate_cache_bytes",
    "open_source",
    "png_header",
    "read_depth_png",
    "select_drives",
    "split_by_drive",
    "subset",
    "write_depth_png",
]
