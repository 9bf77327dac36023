"""Hostile files through every reader and writer of inpaintenv.data: FIFOs, bombs, sparse giants, links, bad names.

Each reader goes through the safe file layer (inpaintenv.files): a FIFO or device is refused at once and said to be
one, a declared size beyond the limits of inpaintenv.files.limits is refused before anything is decoded or
allocated, and every write replaces its target instead of writing through a link.
"""

from __future__ import annotations

import os
import signal
import struct
import subprocess
import sys
import textwrap
import zipfile
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from inpaintenv.data import (
    Calibration,
    CalibrationError,
    ScanFormatError,
    depth_to_points,
    project_scan,
    read_calibration,
    read_depth_file,
    read_mask_file,
    read_scan,
    write_depth_file,
    write_points_bin,
    write_points_ply,
)
from inpaintenv.data.calibration import parse_size
from inpaintenv.exceptions import FileTooLargeError, UnsafeFileError
from inpaintenv.files import MAX_SCAN_POINTS

K = "7.215377e+02 0 6.095593e+02 0 0 7.215377e+02 1.728540e+02 0 0 0 1 0"
IDENTITY = "1 0 0 0 1 0 0 0 1"


@pytest.fixture
def no_hang():
    """Fail a read that would wait on a FIFO instead of hanging the suite."""
    def timeout(signum, frame):
        raise TimeoutError("the read waited on a FIFO")

    old = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(10)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def _npy_header(shape: tuple[int, ...], descr: str = "<f4") -> bytes:
    header = repr({"descr": descr, "fortran_order": False, "shape": shape}).encode()
    header += b" " * (118 - len(header)) + b"\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header


def _png(width: int, height: int, bit_depth: int, color_type: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(bytes(1 << 16)))
            + chunk(b"IEND", b""))


def _sparse(path: Path, head: bytes, size: int) -> Path:
    """``head`` followed by a hole up to ``size`` bytes: a giant file that costs no disk."""
    path.write_bytes(head)
    os.truncate(path, size)
    return path


# -- a mask named in bytes that are not UTF-8 ----------------------------------------------------------

def test_a_mask_whose_name_is_not_utf8_is_read(tmp_path):
    # cv2.imread(str(path)) crashed the interpreter (SIGSEGV) on such a name.
    script = textwrap.dedent("""
        import os, sys
        from pathlib import Path
        import cv2, numpy as np
        from inpaintenv.data import read_mask_file
        path = Path(sys.argv[1]) / os.fsdecode(b"mask-\\xff\\xfe.png")
        path.write_bytes(cv2.imencode(".png", np.array([[0, 255], [0, 9]], np.uint8))[1].tobytes())
        print(read_mask_file(path).tolist())
    """)
    done = subprocess.run([sys.executable, "-c", script, str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[[False, True], [False, True]]"


# -- declared sizes checked before anything is decoded or allocated -------------------------------------

def test_a_mask_png_bomb_is_refused_from_its_header(tmp_path):
    # 20000 x 20000 RGBA16 is 3.2 GB decoded; cv2.imread decoded it.
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png(20000, 20000, 16, 6))
    with pytest.raises(FileTooLargeError, match=r"bomb\.png declares 20000 x 20000 = 400,000,000 pixels.*MAX_FRAME"):
        read_mask_file(bomb)


@pytest.mark.parametrize("read", [read_depth_file, read_mask_file])
def test_a_sparse_giant_npy_is_refused_from_its_header(tmp_path, read):
    # 3.6 GB declared and present (sparse): np.load read it whole.
    big = _sparse(tmp_path / "big.npy", _npy_header((30000, 30000)), 128 + 30000 * 30000 * 4)
    with pytest.raises(FileTooLargeError, match=r"big\.npy declares an array of shape \(30000, 30000\)"):
        read(big)


@pytest.mark.parametrize("read", [read_depth_file, read_mask_file])
def test_an_npz_member_is_checked_before_it_is_inflated(tmp_path, read):
    # A small .npz whose member declares 60000 x 60000 values: np.load inflated it.
    bomb = tmp_path / "bomb.npz"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("depth.npy", _npy_header((60000, 60000), "<f8") + bytes(1 << 20))
    with pytest.raises(FileTooLargeError, match=r"array 'depth' of .*bomb\.npz declares an array of shape"):
        read(bomb)


def _patched_zip(path: Path, signature: bytes, offset: int, value: int) -> Path:
    """An .npz of one small array with the 4-byte field at ``offset`` of its ``signature`` record set to ``value``."""
    np.savez(path, depth=np.ones((8, 8)))
    data = bytearray(path.read_bytes())
    at = data.rfind(signature)
    data[at + offset:at + offset + 4] = struct.pack("<I", value)
    path.write_bytes(bytes(data))
    return path


def test_the_zip_directory_of_an_npz_is_checked_before_it_is_parsed(tmp_path):
    huge_member = _patched_zip(tmp_path / "member.npz", b"PK\x01\x02", 24, 0xF0000000)  # uncompressed size
    with pytest.raises(FileTooLargeError, match=r"member 'depth.npy' of .*member\.npz declares 4,026,531,840 bytes"):
        read_depth_file(huge_member)
    huge_directory = _patched_zip(tmp_path / "dir.npz", b"PK\x05\x06", 12, 64 << 20)  # directory size
    with pytest.raises(FileTooLargeError, match=r"dir\.npz declares a ZIP directory of 1 entries \(67,108,864 bytes"):
        read_depth_file(huge_directory)


def test_a_scan_larger_than_the_point_limit_is_refused_from_its_size(tmp_path):
    # A 3.2 GB .bin ended in MemoryError.
    big = _sparse(tmp_path / "big.bin", b"", 3_200_000_000)
    with pytest.raises(FileTooLargeError, match=rf"scan {big} is 3,200,000,000 bytes \(200,000,000 points\), more "
                                                rf"than the {MAX_SCAN_POINTS:,} points a scan may have"):
        read_scan(big)


def _kitti360(folder: Path, persp: str, c2v: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "perspective.txt").write_text(persp)
    (folder / "calib_cam_to_velo.txt").write_text(c2v)
    return folder


def _perspective(size: str = "1408 376", p: str = K) -> str:
    return f"calib_time: 09-Jan-2012 14:00:15\nP_rect_00: {p}\nR_rect_00: {IDENTITY}\nS_rect_00: {size}\n"


def test_a_calibrated_image_size_beyond_the_frame_limit_is_refused(tmp_path):
    folder = _kitti360(tmp_path / "calibration", _perspective("32768 32768"), "1 0 0 0 0 1 0 0 0 0 1 0")
    with pytest.raises(FileTooLargeError, match=r"perspective\.txt: S_rect_00 32768x32768 declares 32768 x 32768"):
        read_calibration(folder)
    with pytest.raises(FileTooLargeError, match=r"image size 32768x32768 declares"):
        parse_size("32768x32768")
    assert parse_size("1226x370") == (1226, 370)


# -- a calibration that passes the determinant check but gives infinite points ---------------------------

def test_a_badly_conditioned_calibration_is_refused_with_its_file(tmp_path):
    calib = tmp_path / "calib.txt"
    calib.write_text("P2: 1e200 0 0 0 0 1e200 0 0 0 0 1e-300 0\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(CalibrationError, match=rf"{calib}: the projection matrix is badly conditioned"):
        read_calibration(calib, size=(64, 32))


def test_projection_and_back_projection_are_finite_or_refused():
    huge = Calibration(1e300 * np.array([[700.0, 0, 30, 0], [0, 700, 16, 0], [0, 0, 1, 0]]), (64, 32), "odometry",
                       Path("calib.txt"))
    points = np.array([[1e10, 0, 2e10, 0]], np.float32)
    with pytest.raises(CalibrationError, match=r"calibration calib\.txt projects finite points to infinite"):
        project_scan(points, huge)
    plain = Calibration(np.array([[700.0, 0, 30, 0], [0, 700, 16, 0], [0, 0, 1, 0]]), (64, 32), "odometry",
                        Path("calib.txt"))
    with pytest.raises(CalibrationError, match=r"calibration calib\.txt back-projects depth to infinite"):
        depth_to_points(np.full((4, 4), 1e308), plain)
    assert np.isfinite(depth_to_points(np.full((4, 4), 10.0), plain)).all()


def test_a_scan_with_nan_coordinates_is_refused_with_its_name(tmp_path):
    path = tmp_path / "nan.bin"
    path.write_bytes(np.array([[1, 2, 3, 0], [np.nan, 0, 5, 0]], "<f4").tobytes())
    with pytest.raises(ScanFormatError, match=r"nan\.bin: 1 of its 2 points have a NaN"):
        read_scan(path)


# -- a FIFO or device is refused at once and said to be one ----------------------------------------

@pytest.mark.parametrize("name, read", [
    ("a.png", read_depth_file), ("a.npy", read_depth_file), ("a.npz", read_depth_file),
    ("m.png", read_mask_file), ("m.npy", read_mask_file), ("s.bin", read_scan),
])
def test_a_fifo_named_like_a_data_file_is_refused_at_once(tmp_path, no_hang, name, read):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    with pytest.raises(UnsafeFileError, match=rf"{name} is a FIFO \(named pipe\), not a regular file"):
        read(fifo)


@pytest.mark.parametrize("layout", ["calib.txt", "raw", "kitti360"])
def test_a_fifo_calibration_is_refused_at_once(tmp_path, no_hang, layout):
    if layout == "calib.txt":
        fifo = tmp_path / "calib.txt"
    elif layout == "raw":
        (tmp_path / "calib_velo_to_cam.txt").write_text(f"R: {IDENTITY}\nT: 0 0 0\n")
        fifo = tmp_path / "calib_cam_to_cam.txt"
    else:
        (tmp_path / "perspective.txt").write_text(_perspective())
        fifo = tmp_path / "calib_cam_to_velo.txt"
    os.mkfifo(fifo)
    with pytest.raises(CalibrationError, match=rf"{fifo.name} is a FIFO \(named pipe\), not a regular file"):
        read_calibration(fifo if layout == "calib.txt" else tmp_path, size=(64, 32))


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_a_device_is_not_called_missing(no_hang):
    with pytest.raises(UnsafeFileError, match="/dev/zero is a device, not a regular file"):
        read_scan("/dev/zero")


# -- KITTI-360 calibration errors name their file --------------------------------------------------------

def test_a_singular_kitti360_calibration_names_its_file(tmp_path):
    folder = _kitti360(tmp_path / "calibration", _perspective(), "1 0 0 0 0 1 0 0 0 0 0 0")
    with pytest.raises(CalibrationError, match=r"calib_cam_to_velo\.txt: T_cam0_to_velo is singular"):
        read_calibration(folder)


def test_a_hex_number_is_refused_with_its_file_and_line(tmp_path):
    folder = _kitti360(tmp_path / "calibration", _perspective(p=K.replace("6.095593e+02", "0x261")),
                       "1 0 0 0 0 1 0 0 0 0 1 0")
    with pytest.raises(CalibrationError, match=r"perspective\.txt line 2: P_rect_00 holds '0x261', not a decimal"):
        read_calibration(folder)
    (folder / "calib_cam_to_velo.txt").write_text("1 0 0 0\n0 1 0 0x0\n0 0 1 0\n")
    (folder / "perspective.txt").write_text(_perspective())
    with pytest.raises(CalibrationError, match=r"calib_cam_to_velo\.txt line 2: '0x0' is not a decimal number"):
        read_calibration(folder)
    calib = tmp_path / "calib.txt"
    calib.write_text(f"P2: {K}\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\nP2: {K}\n")
    with pytest.raises(CalibrationError, match=r"P2 is given on lines 1, 3; give it once"):
        read_calibration(calib, size=(64, 32))


# -- writes: whole or not at all, never through a planted link -----------------------------------------------------

@pytest.mark.parametrize("name, write", [
    ("d.npy", lambda p: write_depth_file(p, np.ones((8, 8)))),
    ("d.npz", lambda p: write_depth_file(p, np.ones((8, 8)))),
    ("d.png", lambda p: write_depth_file(p, np.ones((8, 8)))),
    ("s.bin", lambda p: write_points_bin(p, np.ones((3, 3), np.float32))),
    ("s.ply", lambda p: write_points_ply(p, np.ones((3, 3), np.float32))),
])
def test_data_writers_replace_a_planted_link(tmp_path, name, write):
    victim = tmp_path / "victim"
    victim.write_text("mine")
    target = tmp_path / "out" / name
    target.parent.mkdir()
    target.symlink_to(victim)
    write(target)
    assert victim.read_text() == "mine" and not target.is_symlink() and target.stat().st_size > 0
    assert sorted(p.name for p in target.parent.iterdir()) == [name]
    if name.startswith("d."):
        np.testing.assert_array_equal(read_depth_file(target), np.ones((8, 8)))


def test_mask_pngs_of_any_pixel_format_still_read(tmp_path):
    rgba = np.zeros((4, 5, 4), np.uint16)
    rgba[1, 2, 0] = 7
    rgba[..., 3] = 65535  # alpha says nothing about holes
    (tmp_path / "m.png").write_bytes(cv2.imencode(".png", rgba)[1].tobytes())
    expected = np.zeros((4, 5), bool)
    expected[1, 2] = True
    np.testing.assert_array_equal(read_mask_file(tmp_path / "m.png"), expected)


def test_projection_in_chunks_equals_one_pass(monkeypatch):
    # Scans and frames are projected in chunks (a 16 M-point scan took 1.8 GB at once); the chunks change nothing.
    from inpaintenv.data import projection

    rng = np.random.default_rng(0)
    points = rng.normal(size=(5000, 4)).astype(np.float32) * [4, 2, 0.5, 1] + [12, 0, 0, 0]
    calib = Calibration(np.array([[30.0, -40, 0, 60], [0, 0, -40, 24], [1, 0, 0, 0]]), (120, 48), "odometry")
    whole = project_scan(points, calib, return_index=True)
    back = depth_to_points(whole[0], calib)
    monkeypatch.setattr(projection, "_CHUNK_POINTS", 333)
    chunked = project_scan(points, calib, return_index=True)
    assert (whole[0] > 0).sum() > 333  # more than one chunk of pixels too
    np.testing.assert_array_equal(whole[0], chunked[0])
    np.testing.assert_array_equal(whole[1], chunked[1])
    np.testing.assert_array_equal(depth_to_points(whole[0], calib), back)
