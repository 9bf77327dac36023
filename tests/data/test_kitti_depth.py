"""KittiDepth on small PNG trees written here (layouts, crop, errors) and on the real slice."""

from __future__ import annotations

import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from inpaintenv.data import (
    KITTI_URL,
    DepthFormatError,
    KittiDepth,
    Subset,
    read_depth_png,
    write_depth_png,
)

CROP = (8, 12)


def _frame(h: int, w: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    d = np.round(rng.uniform(1, 80, size=(h, w)) * 256) / 256
    d[rng.random((h, w)) < 0.3] = 0.0
    return d


def make_split(root: Path, split: str, drives: dict[str, tuple[int, int]], n: int = 3,
               cameras=("image_02",), kinds=("groundtruth", "velodyne_raw")) -> dict[Path, np.ndarray]:
    """Write ``n`` frames per drive/camera/kind of raw size ``(W, H)``; return path -> depth."""
    written = {}
    for k, (drive, (w, h)) in enumerate(drives.items()):
        for cam in cameras:
            for kind in kinds:
                for i in range(n):
                    path = root / split / f"{drive}_sync" / "proj_depth" / kind / cam / f"{5 + i:010d}.png"
                    depth = _frame(h, w, seed=zlib.crc32(f"{k}/{cam}/{kind}/{i}".encode()))
                    write_depth_png(path, depth)
                    written[path] = depth
    return written


@pytest.fixture
def tree(tmp_path) -> Path:
    make_split(tmp_path, "train", {"2011_09_26_drive_0001": (20, 16), "2011_09_28_drive_0002": (19, 15)},
               cameras=("image_02", "image_03"))
    make_split(tmp_path, "val", {"2011_10_03_drive_0047": (21, 17)}, n=2)
    return tmp_path


def test_train_layout_index_and_crop(tree):
    ds = KittiDepth(tree, split="train", crop=CROP)
    assert len(ds) == 6 and ds.frame_shape == CROP and ds.shape == (6, *CROP)
    assert list(np.unique(ds.groups)) == ["2011_09_26_drive_0001_sync", "2011_09_28_drive_0002_sync"]
    assert ds.frame_ids[0] == "2011_09_26_drive_0001_sync/image_02/0000000005"
    assert ds.frame_ids == sorted(ds.frame_ids)
    for i in (0, 4):  # one frame of each raw size: 20x16 and 19x15
        raw = read_depth_png(ds.paths[i])
        h, w = raw.shape
        top, left = h - CROP[0], (w - CROP[1]) // 2
        np.testing.assert_array_equal(ds[i], raw[top:, left : left + CROP[1]])
        assert ds[i].dtype == np.float32
    assert isinstance(ds[[0, 2]], Subset)


def test_velodyne_and_val(tree):
    raw = KittiDepth(tree, split="train", kind="velodyne_raw", crop=CROP)
    assert all("velodyne_raw" in str(p) for p in raw.paths)
    val = KittiDepth(tree, split="val", crop=None)
    assert len(val) == 2 and val.frame_shape == (17, 21)


def test_both_cameras_share_the_drive_group(tree):
    ds = KittiDepth(tree, split="train", camera="both", crop=CROP)
    assert len(ds) == 12
    cams = {fid.split("/")[1] for fid in ds.frame_ids}
    assert cams == {"image_02", "image_03"}
    assert len(np.unique(ds.groups)) == 2
    right = KittiDepth(tree, split="train", camera="image_03", crop=CROP)
    assert all("/image_03/" in f for f in right.frame_ids)


def test_drives_filter(tree):
    ds = KittiDepth(tree, split="train", crop=CROP, drives=["2011_09_28_drive_0002_sync"])
    assert set(ds.groups) == {"2011_09_28_drive_0002_sync"} and len(ds) == 3
    with pytest.raises(ValueError, match="drives not found"):
        KittiDepth(tree, split="train", crop=CROP, drives=["2011_01_01_drive_9999_sync"])


def test_crop_none_requires_one_size(tree):
    with pytest.raises(ValueError, match=r"20x16 \(3 frames\), .*19x15|19x15 \(3 frames\).*20x16"):
        KittiDepth(tree, split="train", crop=None)


def test_frame_smaller_than_crop(tree):
    ds = KittiDepth(tree, split="train", crop=(16, 20))
    ds[0]  # 20x16 fits exactly
    with pytest.raises(ValueError, match="smaller than the crop"):
        ds[4]  # 19x15 does not


def test_val_selection_layout(tmp_path):
    base = tmp_path / "depth_selection" / "val_selection_cropped"
    names = []
    for drive, frame, cam in [("2011_09_26_drive_0002", 5, "image_02"), ("2011_09_26_drive_0002", 6, "image_03"),
                              ("2011_10_03_drive_0047", 10, "image_02")]:
        for folder in ("groundtruth_depth", "velodyne_raw"):
            name = f"{drive}_sync_{folder}_{frame:010d}_{cam}.png"
            write_depth_png(base / folder / name, _frame(*CROP, seed=frame))
        names.append(name)
    ds = KittiDepth(tmp_path, split="val_selection", camera="both", crop=CROP)
    assert len(ds) == 3
    assert ds.frame_ids[0] == "2011_09_26_drive_0002_sync/image_02/0000000005"
    assert list(ds.groups) == ["2011_09_26_drive_0002_sync"] * 2 + ["2011_10_03_drive_0047_sync"]
    left = KittiDepth(tmp_path, split="val_selection", kind="velodyne_raw", crop=CROP)
    assert len(left) == 2 and all("velodyne_raw" in p.name for p in left.paths)
    (base / "groundtruth_depth" / "junk.png").write_bytes(b"")
    with pytest.raises(ValueError, match="unexpected file name junk.png"):
        KittiDepth(tmp_path, split="val_selection")


def test_root_from_environment(tree, monkeypatch):
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tree))
    assert len(KittiDepth(split="val", crop=CROP)) == 2
    monkeypatch.delenv("INPAINTENV_KITTI_ROOT")
    with pytest.raises(FileNotFoundError, match="INPAINTENV_KITTI_ROOT is not set") as err:
        KittiDepth()
    assert KITTI_URL in str(err.value) and "proj_depth" in str(err.value)


def test_missing_root_split_and_empty_tree(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        KittiDepth(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="split folder .*train.* not found"):
        KittiDepth(tmp_path)
    (tmp_path / "train" / "2011_09_26_drive_0001_sync" / "proj_depth").mkdir(parents=True)
    with pytest.raises(FileNotFoundError, match=r"no depth PNGs found: searched .*proj_depth/groundtruth/image_02/\*\.png"):
        KittiDepth(tmp_path)


def _single_file_tree(tmp_path: Path, image: np.ndarray) -> Path:
    path = tmp_path / "train" / "d_sync" / "proj_depth" / "groundtruth" / "image_02" / "0000000005.png"
    path.parent.mkdir(parents=True)
    cv2.imwrite(str(path), image)
    return path


def test_eight_bit_tree_rejected_at_init(tmp_path):
    _single_file_tree(tmp_path, np.ones((16, 20), np.uint8))
    with pytest.raises(DepthFormatError, match="8-bit"):
        KittiDepth(tmp_path, crop=CROP)


def test_rgb_tree_rejected_at_init(tmp_path):
    _single_file_tree(tmp_path, np.ones((16, 20, 3), np.uint16))
    with pytest.raises(DepthFormatError, match="RGB"):
        KittiDepth(tmp_path, crop=None)


def test_corrupt_file_named_on_access(tree):
    ds = KittiDepth(tree, split="train", crop=CROP)
    path = ds.paths[1]
    path.write_bytes(path.read_bytes()[:60])  # header intact, data truncated
    ds = KittiDepth(tree, split="train", crop=CROP)  # indexing does not decode
    with pytest.raises(DepthFormatError, match=path.name):
        ds[1]


@pytest.mark.parametrize("kwargs, match", [({"kind": "dense"}, "kind"), ({"camera": "image_01"}, "camera"),
                                           ({"crop": (0, 5)}, "crop"), ({"crop": (8,)}, "crop"),
                                           ({"crop": ("a", "b")}, r"crop must be \(H, W\) positive integers"),
                                           ({"crop": 5}, "crop must be"), ({"crop": (True, 5)}, "crop must be"),
                                           ({"drives": []}, "drives is empty")])
def test_bad_arguments(tree, kwargs, match):
    with pytest.raises(ValueError, match=match):
        KittiDepth(tree, **kwargs)


@pytest.mark.parametrize("kwargs, match", [({"split": None}, "split must be 'train', 'val' or 'val_selection', got None"),
                                           ({"drives": "2011_09_26_drive_0001_sync"}, "drives must be a list")])
def test_bad_argument_types(tree, kwargs, match):
    with pytest.raises(TypeError, match=match):
        KittiDepth(tree, **kwargs)


def test_summary(tree):
    s = KittiDepth(tree, split="train", crop=CROP).summary(n_sample=3)
    assert s["frames"] == 6 and s["drives"] == 2 and s["sampled_frames"] == 3
    assert s["frames_per_drive"] == {"2011_09_26_drive_0001_sync": 3, "2011_09_28_drive_0002_sync": 3}
    assert s["raw_sizes"] == {"19x15": 3, "20x16": 3}
    assert 0.5 < s["valid_density"] < 0.9  # the written frames are 70 % valid


# --------------------------------------------------------------------------- real slice
@pytest.mark.kitti
def test_real_train_slice(kitti_root, kitti_layout):
    ds = KittiDepth(kitti_root, split="train")
    on_disk = kitti_layout("train")
    assert len(ds) == sum(on_disk.values()) and ds.frame_shape == (352, 1216)
    drives, counts = np.unique(ds.groups, return_counts=True)
    assert dict(zip(drives, counts.tolist())) == on_disk
    # KITTI's raw frame size is fixed per recording day (calibration): every frame has one
    # of the day sizes KITTI ships, and all frames of one day share it.
    sizes = ds.raw_sizes()
    assert sum(sizes.values()) == len(ds)
    assert set(sizes) <= {(1242, 375), (1224, 370), (1226, 370), (1238, 374), (1241, 376)}
    day_sizes: dict[str, set] = {}
    for drive, header in zip(ds.groups, ds.headers()):
        day_sizes.setdefault(drive[:10], set()).add((header.width, header.height))
    assert all(len(s) == 1 for s in day_sizes.values()), day_sizes
    d = ds[10]
    valid = d[d > 0]
    assert 0.1 < valid.size / d.size < 0.5  # semi-dense
    assert 2.0 < np.median(valid) < 40.0 and valid.max() < 90.0  # metres, not raw uint16
    assert not d[:20].any()  # nothing above the LiDAR's field of view


@pytest.mark.kitti
def test_real_val_frame_is_cropped(kitti_root):
    raw = KittiDepth(kitti_root, split="val", crop=None)
    assert raw.frame_shape == (376, 1241)
    ds = KittiDepth(kitti_root, split="val")
    assert len(ds) == 1 and ds[0].shape == (352, 1216)
    assert list(ds.groups) == ["2011_10_03_drive_9101_sync"]
    np.testing.assert_array_equal(ds[0], raw[0][376 - 352 :, 12 : 12 + 1216])
    vel = KittiDepth(kitti_root, split="val", kind="velodyne_raw")[0]
    assert 0.02 < (vel > 0).mean() < 0.08


def test_pickles_for_worker_processes(tree):
    import pickle

    ds = KittiDepth(tree, split="train", crop=CROP)
    again = pickle.loads(pickle.dumps(ds))
    np.testing.assert_array_equal(again[3], ds[3])
    assert again.frame_ids == ds.frame_ids


def test_a_split_typo_is_one_line_without_download_help(tree):
    # The 6-line download hint followed even `--split vall`.
    with pytest.raises(ValueError) as err:
        KittiDepth(tree, split="vall")
    assert str(err.value) == ("unknown KITTI split 'vall': splits are 'train', 'val' and 'val_selection'; "
                              "did you mean 'val'?")
    assert KITTI_URL not in str(err.value)


def test_eight_bit_file_after_the_first_is_found_when_decoded_or_by_headers(tree, capsys):
    # docs/data.md said "rejected at creation"; only the first file's header is read then.
    ds = KittiDepth(tree, split="train", crop=CROP)
    bad = ds.paths[2]
    cv2.imwrite(str(bad), np.ones((16, 20), np.uint8))
    ds = KittiDepth(tree, split="train", crop=CROP)  # created: the first file is 16-bit
    ds[0]
    with pytest.raises(DepthFormatError, match=f"{bad.name}.*8-bit"):
        ds[2]
    with pytest.raises(DepthFormatError, match=f"{bad.name} is a 8-bit PNG"):
        KittiDepth(tree, split="train", crop=CROP).headers()  # what `inpaintenv info` reads
    text = " ".join((Path(__file__).resolve().parents[2] / "docs" / "data.md").read_text().split())
    assert "only the **first** file's header is" in text and "rejected at creation" not in text


def test_upper_case_png_frames_are_indexed(tmp_path):
    # `.PNG` frames were ignored without a word; the file is checked by its signature anyway.
    written = make_split(tmp_path, "train", {"2011_09_26_drive_0001": (20, 16)}, kinds=("groundtruth",))
    first = sorted(written)[0]
    upper = first.with_suffix(".PNG")
    first.rename(upper)
    ds = KittiDepth(tmp_path, crop=CROP)
    assert len(ds) == 3 and upper in ds.paths
    np.testing.assert_array_equal(read_depth_png(upper), written[first].astype(np.float32))
    write_depth_png(first, written[first])  # the same frame twice: which one to score is not ours to pick
    with pytest.raises(ValueError, match=r"two files hold frame 2011_09_26_drive_0001_sync/image_02/0000000005"):
        KittiDepth(tmp_path, crop=CROP)


def _deny_listing(monkeypatch, folder: Path) -> None:
    """Listing ``folder`` fails as for a folder without permission (tests run as root, who may list anything)."""
    import os

    real = os.scandir

    def scandir(path="."):
        if Path(path) == folder:
            raise PermissionError(13, "Permission denied", str(path))
        return real(path)

    monkeypatch.setattr(os, "scandir", scandir)


def test_unreadable_drive_folder_is_an_error_not_missing_frames(tree, monkeypatch):
    # An unreadable drive disappeared from the dataset without a word (18 -> 6 frames).
    folder = tree / "train" / "2011_09_28_drive_0002_sync" / "proj_depth" / "groundtruth" / "image_02"
    assert len(KittiDepth(tree, crop=CROP)) == 6
    _deny_listing(monkeypatch, folder)
    with pytest.raises(PermissionError, match=f"permission denied listing {folder}: its depth PNGs cannot be indexed"):
        KittiDepth(tree, crop=CROP)
    # A drive that is not asked for is not listed, so it does not stop the others.
    assert len(KittiDepth(tree, crop=CROP, drives=["2011_09_26_drive_0001_sync"])) == 3
    _deny_listing(monkeypatch, tree / "train")
    with pytest.raises(PermissionError, match="permission denied listing"):
        KittiDepth(tree, crop=CROP)


def test_names_that_are_not_utf8_become_readable_ids(tmp_path):
    # A drive or frame name with a byte that is not UTF-8 reached reports as a surrogate
    # escape, which no UTF-8 table, CSV or hash can hold; the file path stays as it is.
    import os

    drive = os.fsdecode(b"2011_09_26_drive_\xe9_sync")
    path = tmp_path / "train" / drive / "proj_depth" / "groundtruth" / "image_02" / os.fsdecode(b"0000000005\xfe.png")
    write_depth_png(path, _frame(16, 20, seed=0))
    ds = KittiDepth(tmp_path, crop=CROP)
    assert ds.paths == [path] and list(ds.groups) == ["2011_09_26_drive_\\xe9_sync"]
    assert ds.frame_ids == ["2011_09_26_drive_\\xe9_sync/image_02/0000000005\\xfe"]
    ",".join([*ds.frame_ids, repr(ds), str(ds.summary())]).encode("utf-8")  # no surrogate left
    # The drive selects under either spelling: as typed in a shell (surrogate) or as shown.
    assert len(KittiDepth(tmp_path, crop=CROP, drives=[drive])) == 1
    assert len(KittiDepth(tmp_path, crop=CROP, drives=["2011_09_26_drive_\\xe9_sync"])) == 1
    from inpaintenv.data import select_drives

    assert len(select_drives(ds, [drive])) == 1
