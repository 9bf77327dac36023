"""Real KITTI depth-completion data, read lazily from the official folder layout.

Two layouts are understood (both exactly as downloaded from the KITTI website)::

    <root>/<split>/<drive>_sync/proj_depth/<kind>/<camera>/<frame>.png          split = train | val
    <root>/depth_selection/val_selection_cropped/<kind>_depth|velodyne_raw/
        <drive>_sync_<groundtruth_depth|velodyne_raw>_<frame>_<camera>.png      split = val_selection

Files are indexed once when the dataset is created; pixels are decoded on access.
"""

from __future__ import annotations

import difflib
import os
import re
from collections import Counter
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..progress import count
from .base import DepthDataset, name_from_path
from .io import (
    DepthFormatError,
    PngHeader,
    check_depth_header,
    depth_from_uint16,
    png_header,
    read_depth_png_raw,
)
from ..exceptions import CalibrationError, InvalidInputError, InvalidTypeError
from .calibration import Calibration, read_calibration
from .inputs import check_input_kind, input_kind

__all__ = ["KittiDepth", "KITTI_URL", "KITTI_ROOT_ENV", "png_header", "bottom_center_crop", "scan_calibration"]

#: Where to download the KITTI depth-completion data.
KITTI_URL = "https://www.cvlibs.net/datasets/kitti/eval_depth.php?benchmark=depth_completion"
#: Environment variable read when ``root`` is not given.
KITTI_ROOT_ENV = "INPAINTENV_KITTI_ROOT"

_LAYOUT_HELP = (
    f"Download 'annotated depth maps' and 'projected raw LiDaR scans' (and optionally the "
    f"'validation and test sets') from {KITTI_URL} and unzip them into one folder, giving\n"
    "  <root>/train/<drive>_sync/proj_depth/{groundtruth,velodyne_raw}/image_0{2,3}/*.png\n"
    "  <root>/val/<drive>_sync/proj_depth/{groundtruth,velodyne_raw}/image_0{2,3}/*.png\n"
    "  <root>/depth_selection/val_selection_cropped/{groundtruth_depth,velodyne_raw}/*.png\n"
    f"then pass root=<root> (CLI: --kitti-root) or set ${KITTI_ROOT_ENV}."
)

_KINDS = ("groundtruth", "velodyne_raw")
_SPLITS = ("train", "val", "val_selection")
_CAMERAS = ("image_02", "image_03")
# File names of depth_selection/val_selection_cropped, e.g.
# 2011_09_26_drive_0002_sync_groundtruth_depth_0000000005_image_02.png
_VAL_SELECTION_RE = re.compile(
    r"^(?P<drive>.+_sync)_(?:groundtruth_depth|velodyne_raw)_(?P<frame>\d+)_(?P<camera>image_0[23])\.(?i:png)$"
)


def bottom_center_crop(
    depth: np.ndarray, crop: tuple[int, int], name: str = "frame", *, copy: bool = True
) -> np.ndarray:
    """Crop ``(H, W)`` to ``crop`` keeping the bottom rows and the centre columns.

    The bottom is kept because KITTI's LiDAR sees nothing in the top rows (sky), and
    the centre because raw widths differ by a few pixels between recording days.
    With ``copy=False`` the result is a (non-contiguous) view of ``depth``.
    """
    ch, cw = crop
    h, w = depth.shape
    if h < ch or w < cw:
        raise InvalidInputError(f"{name} is {w}x{h} (W x H), smaller than the crop {cw}x{ch}")
    top, left = h - ch, (w - cw) // 2
    view = depth[top:, left : left + cw]
    return np.ascontiguousarray(view) if copy else view


def scan_calibration(
    root: Path, frame_id: str, file_size: tuple[int, int], frame_shape: tuple[int, int],
) -> Calibration:
    """The projection a KITTI frame's scan was made with, as the frame is read (cropped).

    Parameters
    ----------
    root : Path
        The KITTI root; each day's calibration is at ``<root>/calib/<day>/`` (a raw day
        folder or an odometry ``calib.txt``, see :func:`~inpaintenv.data.calibration.read_calibration`).
    frame_id : str
        ``<drive>/<camera>/<frame>``: the day is the drive's first 10 characters.
    file_size : (int, int)
        ``(width, height)`` of the scan's PNG (a bottom-centre crop of the camera image, or all of it).
    frame_shape : (int, int)
        ``(H, W)`` the frame is read at (the file's bottom-centre crop).

    Raises
    ------
    CalibrationError
        No calibration of the frame's day under ``root/calib``, naming the folder.
    """
    drive, camera = frame_id.split("/")[:2]
    folder = Path(root) / "calib" / drive[:10]
    if not folder.is_dir():
        raise CalibrationError(
            f"{folder} not found: a ring-thinned input finds each scan's laser rings from its day's calibration "
            "(<root>/calib/<day>/: a KITTI raw day folder, calib_cam_to_cam.txt + calib_velo_to_cam.txt, or an odometry "
            "calib.txt)")
    calib = read_calibration(folder, camera=int(camera[-1]))
    full_w, full_h = calib.size or file_size
    h, w = frame_shape
    # The frame is a bottom-centre crop of the file, itself one of the camera image: shift the principal point.
    left = (full_w - file_size[0]) // 2 + (file_size[0] - w) // 2
    top = full_h - h
    shift = np.array([[1.0, 0.0, -left], [0.0, 1.0, -top], [0.0, 0.0, 1.0]])
    return Calibration(shift @ calib.matrix, (w, h), calib.kind, calib.source, calib.camera)


class KittiDepth(DepthDataset):
    """KITTI depth-completion frames in metres, read lazily from the official layout.

    Parameters
    ----------
    root : path-like, optional
        Folder holding ``train/``, ``val/`` and/or ``depth_selection/``. By default
        ``$INPAINTENV_KITTI_ROOT``.
    split : {"train", "val", "val_selection"}
        ``val_selection`` is ``depth_selection/val_selection_cropped`` (1000 frames,
        already 352x1216).
    camera : {"image_02", "image_03", "both"}
        Left, right or both colour cameras (both cameras of a drive share its group).
    kind : {"groundtruth", "velodyne_raw"}
        Semi-dense accumulated ground truth, or the single-scan LiDAR input.
    crop : (int, int) or None
        ``(H, W)`` bottom-centre crop applied to every frame (KITTI's raw sizes differ:
        1242x375, 1224x370, 1238x374, 1241x376). ``None`` keeps the raw size, which is
        only allowed if all frames share one size.
    drives : list or tuple of str, optional
        Only these drives (e.g. ``"2011_09_26_drive_0001_sync"``); must not be empty.
    input : {"map", "scan"}
        What a method is given (:mod:`inpaintenv.data.inputs`): the frame itself, or
        (``"scan"``, with ``kind="groundtruth"``) the frame's own single scan
        (``velodyne_raw``), cropped like it; frames without both files are left out.

    Attributes
    ----------
    groups : numpy.ndarray
        The drive id of each frame.
    frame_ids : list of str
        ``"<drive>/<camera>/<frame>"``.
    paths : list of pathlib.Path
        The PNG of each frame.
    input_paths : list of pathlib.Path
        The PNG of each frame's input (its scan for ``input="scan"``, else ``paths``).

    Examples
    --------
    >>> ds = KittiDepth("/data/kitti", split="val")          # doctest: +SKIP
    >>> depth = ds[0]                                         # doctest: +SKIP
    >>> depth.shape, depth.dtype                              # doctest: +SKIP
    ((352, 1216), dtype('float32'))
    """

    def __init__(
        self,
        root: str | os.PathLike | None = None,
        split: str = "train",
        camera: str = "image_02",
        kind: str = "groundtruth",
        crop: tuple[int, int] | None = (352, 1216),
        drives: list[str] | tuple[str, ...] | None = None,
        input: str = "map",
    ):
        if not isinstance(split, str):
            raise InvalidTypeError(f"split must be 'train', 'val' or 'val_selection', got {split!r}")
        if split not in _SPLITS:
            # A typo, not missing data: no download instructions.
            close = difflib.get_close_matches(split, _SPLITS, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise InvalidInputError(f"unknown KITTI split {split!r}: splits are 'train', 'val' and 'val_selection'{hint}")
        if kind not in _KINDS:
            raise InvalidInputError(f"kind must be one of {_KINDS}, got {kind!r}")
        self.input_kind = check_input_kind(input)
        scans = input_kind(input).separate
        if scans and kind != "groundtruth":
            raise InvalidInputError(f"input={input!r} pairs a scan with its ground truth: kind must be 'groundtruth', "
                                    f"got {kind!r}")
        if camera not in (*_CAMERAS, "both"):
            raise InvalidInputError(f"camera must be 'image_02', 'image_03' or 'both', got {camera!r}")
        if crop is not None:
            # Check the type before comparing: int('a') or len(5) would fail obscurely.
            if (
                not isinstance(crop, (tuple, list))
                or len(crop) != 2
                or not all(_is_whole(c) and c > 0 for c in crop)
            ):
                raise InvalidInputError(f"crop must be (H, W) positive integers or None, got {crop!r}")
            crop = (int(crop[0]), int(crop[1]))
        if drives is not None:
            if isinstance(drives, str) or not isinstance(drives, (list, tuple)):
                raise InvalidTypeError(f"drives must be a list of drive names, got {drives!r}")
            if not drives:
                # Otherwise every file is filtered out and the error says no PNG exists.
                raise InvalidInputError("drives is empty; pass None for every drive")
        self.root = _resolve_root(root)
        self.split, self.camera, self.kind, self.crop = split, camera, kind, crop
        cameras = _CAMERAS if camera == "both" else (camera,)

        wanted = None if drives is None else {name_from_path(str(d)) for d in drives}
        index = _index_val_selection if split == "val_selection" else partial(_index_split, split=split)
        # Only the wanted drives are listed, so an unreadable drive left out does not stop the run.
        entries, searched = index(self.root, kind=kind, cameras=cameras, drives=wanted)
        if wanted is not None:
            missing = sorted(wanted - {e[1] for e in entries})
            if missing:
                available = sorted({e[1] for e in index(self.root, kind=kind, cameras=cameras)[0]})
                raise InvalidInputError(
                    f"drives not found in {split!r} ({kind}, {camera}): {missing}; "
                    f"available: {available}"
                )
        _refuse_twins(entries)
        if not entries:
            raise FileNotFoundError(f"no depth PNGs found: searched {searched}\n{_LAYOUT_HELP}")
        entries.sort(key=lambda e: (e[1], e[2], e[3]))  # drive, camera, frame
        if scans:
            entries = _pair_with_scans(entries, index(self.root, kind="velodyne_raw", cameras=cameras, drives=wanted))

        self.paths: list[Path] = [e[0] for e in entries]
        self.input_paths: list[Path] = [e[-1] for e in entries] if scans else self.paths
        self._calibrations: dict[tuple[tuple[int, int], str], Calibration] = {}
        self.groups = np.asarray([e[1] for e in entries])
        self.frame_ids = [f"{e[1]}/{e[2]}/{e[3]}" for e in entries]
        self._headers: list[PngHeader] | None = None

        if crop is None:
            sizes = self.raw_sizes()
            if len(sizes) != 1:
                listing = ", ".join(f"{w}x{h} ({n} frames)" for (w, h), n in sorted(sizes.items()))
                raise InvalidInputError(
                    f"frames have different sizes (W x H): {listing}; pass crop=(H, W), "
                    "e.g. the default (352, 1216), to crop them to one size"
                )
            (w, h), = sizes
            self.frame_shape = (h, w)
        else:
            # Reject 8-bit/RGB trees early from the first file's header; the rest is
            # checked when decoded.
            check_depth_header(self.paths[0], png_header(self.paths[0]))
            check_depth_header(self.input_paths[0], png_header(self.input_paths[0]))
            self.frame_shape = crop

    # -- loading -----------------------------------------------------------------
    def _load(self, index: int) -> np.ndarray:
        return self._read(self.paths[index])

    def _load_scan(self, index: int) -> np.ndarray:
        return self._read(self.input_paths[index])

    def _scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        header = png_header(self.input_paths[index])
        key = ((header.width, header.height), self.frame_ids[index].rsplit("/", 1)[0])
        if key not in self._calibrations:  # one per drive, camera and file size
            self._calibrations[key] = scan_calibration(self.root, self.frame_ids[index], key[0], self.frame_shape)
        return self._calibrations[key], None

    def _read(self, path: Path) -> np.ndarray:
        raw = read_depth_png_raw(path)
        if self.crop is None:
            if raw.shape != self.frame_shape:
                raise DepthFormatError(
                    f"{path} is {raw.shape[1]}x{raw.shape[0]}, expected "
                    f"{self.frame_shape[1]}x{self.frame_shape[0]} (file changed since indexing?)"
                )
        else:
            # Crop the uint16 values first: only the kept pixels are converted, in one pass.
            raw = bottom_center_crop(raw, self.crop, name=str(path), copy=False)
        return depth_from_uint16(raw)

    # -- description -------------------------------------------------------------
    def headers(self) -> list[PngHeader]:
        """The PNG header of every frame (read once, then cached); checks the pixel format."""
        if self._headers is None:
            headers = []
            for p in self.paths:
                h = png_header(p)
                check_depth_header(p, h)
                headers.append(h)
            self._headers = headers
        return self._headers

    def raw_sizes(self) -> dict[tuple[int, int], int]:
        """Number of frames per raw ``(W, H)`` size, from the PNG headers (no decoding)."""
        return dict(Counter((h.width, h.height) for h in self.headers()))

    def _summary_fields(self) -> dict[str, Any]:
        # raw_sizes: KITTI drives differ in raw frame size (1242x375, 1224x370, ...).
        return {
            "root": name_from_path(str(self.root)),
            "split": self.split,
            "kind": self.kind,
            "input": self.input_kind,
            "camera": self.camera,
            "raw_sizes": {f"{w}x{h}": n for (w, h), n in sorted(self.raw_sizes().items())},
        }

    def __repr__(self) -> str:
        return (
            f"KittiDepth(root={name_from_path(str(self.root))!r}, split={self.split!r}, camera={self.camera!r}, "
            f"kind={self.kind!r}, {'input=' + repr(self.input_kind) + ', ' if self.input_kind != 'map' else ''}"
            f"{count(len(self), 'frame')}, {count(len(np.unique(self.groups)), 'drive')}, "
            f"frame_shape={self.frame_shape})"
        )


def _pair_with_scans(
    entries: list[tuple[Path, str, str, str]], found: tuple[list[tuple[Path, str, str, str]], str]
) -> list[tuple[Path, str, str, str, Path]]:
    """Each ground-truth entry with its frame's scan appended; frames without a scan are left out."""
    scans, searched = found
    _refuse_twins(scans)
    by_key = {tuple(e[1:]): e[0] for e in scans}
    paired = [(*e, by_key[tuple(e[1:])]) for e in entries if tuple(e[1:]) in by_key]
    if not paired:
        raise FileNotFoundError(
            f"no frame has both its ground truth and its scan: scans searched {searched}\n{_LAYOUT_HELP}"
        )
    return paired  # type: ignore[return-value]


def _is_whole(value: object) -> bool:
    """An int, or a float with an integral value (crop sizes read from JSON); not bool or str."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, (int, np.integer)):
        return True
    return isinstance(value, (float, np.floating)) and float(value).is_integer()


def _resolve_root(root: str | os.PathLike | None) -> Path:
    if root is None:
        env = os.environ.get(KITTI_ROOT_ENV, "").strip()
        if not env:
            raise FileNotFoundError(
                f"no KITTI root given and ${KITTI_ROOT_ENV} is not set.\n{_LAYOUT_HELP}\n"
                "(Without KITTI, use the built-in SyntheticStreets data.)"
            )
        root = env
    if isinstance(root, str) and not root.strip():
        # Path("") is the current folder: a KITTI tree would be searched where the command runs.
        raise InvalidInputError("the KITTI root is an empty string; give the folder holding train/ and val/")
    path = Path(root).expanduser()
    if not path.is_dir():
        raise FileNotFoundError(f"KITTI root {path} does not exist or is not a folder.\n{_LAYOUT_HELP}")
    return path


def _refuse_twins(entries: list[tuple[Path, str, str, str]]) -> None:
    """Refuse two files of one frame (``x.png`` and ``x.PNG``): which one is scored would be arbitrary."""
    seen: dict[tuple[str, str, str], Path] = {}
    for path, *key in entries:
        other = seen.setdefault(tuple(key), path)  # type: ignore[arg-type]
        if other != path:
            raise InvalidInputError(f"two files hold frame {'/'.join(key)}: {other} and {path}; keep one")


def _is_png_name(name: str) -> bool:
    """A frame file name: ``.png`` in any case (``.PNG`` too; the content is checked by its signature)."""
    return name.lower().endswith(".png")


def _entries(folder: Path, *, missing_ok: bool = True) -> list[os.DirEntry]:
    """The entries of ``folder``, sorted by name; an unreadable folder is one clear error, never skipped.

    A folder that does not exist (or is a file) gives ``[]`` when ``missing_ok``.

    Raises
    ------
    PermissionError
        The folder (or one above it) cannot be listed: its frames would silently be missing.
    OSError
        Any other listing error (e.g. a loop of symbolic links), naming the folder.
    """
    try:
        with os.scandir(folder) as it:
            return sorted(it, key=lambda e: e.name)
    except (FileNotFoundError, NotADirectoryError):
        if missing_ok:
            return []
        raise FileNotFoundError(f"folder {folder} not found") from None
    except PermissionError:
        raise PermissionError(
            f"permission denied listing {folder}: its depth PNGs cannot be indexed (fix its permissions, "
            "or leave its drive out with drives=[...] / --drives)"
        ) from None
    except OSError as exc:
        raise OSError(f"cannot list {folder}: {exc.strerror or exc}") from None


def _pngs(folder: Path) -> list[Path]:
    """The ``.png`` files (any case) of ``folder``; anything not a folder counts, so a broken link is read and named."""
    return [Path(e.path) for e in _entries(folder) if _is_png_name(e.name) and not e.is_dir()]


def _index_split(
    root: Path, split: str, kind: str, cameras: tuple[str, ...], drives: set[str] | None = None
) -> tuple[list[tuple[Path, str, str, str]], str]:
    base = root / split
    if not base.is_dir():
        present = sorted(e.name for e in _entries(root) if e.is_dir())
        raise FileNotFoundError(
            f"split folder {base} not found (folders in {root}: {present}); splits are "
            f"'train', 'val' or 'val_selection'.\n{_LAYOUT_HELP}"
        )
    entries = []
    for drive_dir in _entries(base):
        drive = name_from_path(drive_dir.name)
        # A drive that is not wanted is not listed: an unreadable one then does not stop the run.
        if not drive.endswith("_sync") or (drives is not None and drive not in drives) or not drive_dir.is_dir():
            continue
        for cam in cameras:
            for png in _pngs(Path(drive_dir.path) / "proj_depth" / kind / cam):
                entries.append((png, drive, cam, name_from_path(png.stem)))
    cams = "{" + ",".join(cameras) + "}" if len(cameras) > 1 else cameras[0]
    return entries, str(base / "*_sync" / "proj_depth" / kind / cams / "*.png")


def _index_val_selection(
    root: Path, kind: str, cameras: tuple[str, ...], drives: set[str] | None = None
) -> tuple[list[tuple[Path, str, str, str]], str]:
    folder = "groundtruth_depth" if kind == "groundtruth" else "velodyne_raw"
    base = root / "depth_selection" / "val_selection_cropped" / folder
    if not base.is_dir():
        raise FileNotFoundError(f"split folder {base} not found for split='val_selection'.\n{_LAYOUT_HELP}")
    entries = []
    for png in _pngs(base):
        m = _VAL_SELECTION_RE.match(png.name)
        if m is None:
            raise InvalidInputError(
                f"unexpected file name {png.name} in {base}; expected "
                f"<drive>_sync_{folder}_<frame>_<camera>.png"
            )
        drive = name_from_path(m["drive"])
        if m["camera"] in cameras and (drives is None or drive in drives):
            entries.append((png, drive, m["camera"], m["frame"]))
    return entries, str(base / f"*_sync_{folder}_*_image_0?.png")
