"""Data sources: real KITTI depth and the built-in synthetic streets, plus splits."""

from .base import (
    ArrayDataset, ConcatDataset, DepthDataset, Subset, as_dataset, select_drives, spaced_per_drive, split_by_drive,
    subset,
)
from .cache import CachedDataset, StaleCacheError, estimate_cache_bytes
from .calibration import Calibration, CalibrationError, read_calibration
from .depth_files import read_depth_file, read_mask_file, write_depth_file
from .inputs import INPUT_KINDS, method_input
from .io import DepthFormatError, read_depth_png, write_depth_png
from .kitti import KITTI_ROOT_ENV, KITTI_URL, KittiDepth, bottom_center_crop, png_header
from .projection import (
    ScanFormatError, depth_to_points, project_points, project_scan, read_scan, write_points_bin, write_points_ply,
)
from .sources import open_source
from .synthetic import SyntheticStreets
from .thinning import laser_rings, ring_map, thin_points_by_rings, thin_points_by_share, thin_scan_by_points, thin_scan_by_rings

__all__ = [
    "ArrayDataset",
    "CachedDataset",
    "Calibration",
    "CalibrationError",
    "ConcatDataset",
    "DepthDataset",
    "DepthFormatError",
    "INPUT_KINDS",
    "KITTI_ROOT_ENV",
    "KITTI_URL",
    "KittiDepth",
    "ScanFormatError",
    "StaleCacheError",
    "Subset",
    "SyntheticStreets",
    "as_dataset",
    "bottom_center_crop",
    "depth_to_points",
    "estimate_cache_bytes",
    "open_source",
    "png_header",
    "project_points",
    "project_scan",
    "read_calibration",
    "read_depth_file",
    "read_depth_png",
    "read_mask_file",
    "read_scan",
    "select_drives",
    "spaced_per_drive",
    "split_by_drive",
    "subset",
    "laser_rings",
    "ring_map",
    "thin_points_by_rings",
    "thin_points_by_share",
    "thin_scan_by_points",
    "thin_scan_by_rings",
    "write_depth_file",
    "write_depth_png",
    "write_points_bin",
    "method_input",
    "write_points_ply",
]
