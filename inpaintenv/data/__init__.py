"""Data sources: real KITTI depth and the built-in synthetic streets, plus splits."""

from .base import ArrayDataset, DepthDataset, Subset, as_dataset, split_by_drive, subset
from .io import DepthFormatError, read_depth_png, write_depth_png

__all__ = [
    "ArrayDataset",
    "DepthDataset",
    "DepthFormatError",
    "Subset",
    "as_dataset",
    "read_depth_png",
    "split_by_drive",
    "subset",
    "write_depth_png",
]
