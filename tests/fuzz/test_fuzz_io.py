"""read_depth_png on hostile files: one clear error naming the file and the problem, never wrong depth.

Kinds of bad file: random bytes, truncated PNGs, other pixel formats, PNG bombs (a small file
declaring a huge frame), other formats named .png (TIFF), names that are not UTF-8, files that
cannot be read (permission denied, folders, loops of links) or written (a full disk).
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import textwrap
import zipfile
import zlib

import cv2
import numpy as np
import pytest
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from inpaintenv.data.io import MAX_FRAME_PIXELS, DepthFormatError, png_header, read_depth_png, write_depth_png
from inpaintenv.exceptions import FileTooLargeError

sizes = st.tuples(st.integers(1, 24), st.integers(1, 40))


def _png_bytes(img: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", img)
    assert ok
    return buf.tobytes()


@fast(40)
@given(data=st.binary(max_size=2048))
def test_random_bytes_are_rejected_or_decoded_as_16_bit(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("bytes") / "x.png"
    path.write_bytes(data)
    try:
        depth = read_depth_png(path)
    except DepthFormatError:
        return
    # Only a genuine single-channel 16-bit image may get through.
    assert depth.ndim == 2 and depth.dtype == np.float32


@fast(30)
@given(size=sizes, seed=st.integers(0, 2**32 - 1), cut=st.floats(0.0, 1.0, exclude_max=True))
def test_truncated_png_is_an_error_or_exact(tmp_path_factory, size, seed, cut):
    codes = np.random.default_rng(seed).integers(0, 2**16, size=size, dtype=np.uint16)
    blob = _png_bytes(codes)
    path = tmp_path_factory.mktemp("trunc") / "x.png"
    path.write_bytes(blob[: int(cut * len(blob))])
    try:
        depth = read_depth_png(path)
    except DepthFormatError:
        return
    # If the decoder accepts a shortened file, the pixels must still be exactly right.
    np.testing.assert_array_equal(depth, codes.astype(np.float32) / 256)


@fast(30)
@given(
    size=sizes,
    seed=st.integers(0, 2**32 - 1),
    layout=st.sampled_from(["gray8", "rgb8", "rgb16", "rgba16", "gray16"]),
)
def test_pixel_formats(tmp_path_factory, size, seed, layout):
    rng = np.random.default_rng(seed)
    dtype = np.uint16 if layout.endswith("16") else np.uint8
    channels = {"gray": (), "rgb": (3,), "rgba": (4,)}[layout[:-2] if layout.endswith("16") else layout[:-1]]
    img = rng.integers(0, np.iinfo(dtype).max + 1, size=(*size, *channels), dtype=dtype)
    path = tmp_path_factory.mktemp("fmt") / "x.png"
    path.write_bytes(_png_bytes(img))
    if layout == "gray16":
        np.testing.assert_array_equal(read_depth_png(path), img.astype(np.float32) / 256)
    else:
        with pytest.raises(DepthFormatError, match="16-bit|channels"):
            read_depth_png(path)


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="absent.png"):
        read_depth_png(tmp_path / "absent.png")
    # A folder is not "not found": it is there, and is a folder.
    with pytest.raises(IsADirectoryError, match=f"{tmp_path} is a folder"):
        read_depth_png(tmp_path)
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(DepthFormatError):
        read_depth_png(tmp_path / "empty.png")


# -- PNG bombs, other formats, pixel formats read from the header ------------------------------
def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_bytes(width: int, height: int, *, bit_depth: int = 16, color_type: int = 0, idat: bytes | None = None) -> bytes:
    """A PNG declaring ``width`` x ``height``; its IDAT is ``idat`` (default: a zlib stream of zeros)."""
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    if idat is None:
        idat = zlib.compress(bytes(1 << 16), 9)  # 64 KiB of zeros in ~100 bytes: a bomb's payload
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", idat) + _chunk(b"IEND", b"")


@pytest.mark.parametrize("side", [60000, 30000])
def test_png_bomb_is_refused_from_its_header_before_decoding(tmp_path, side):
    # 60000^2 gave a raw cv2.error; 30000^2 was decoded at 3.6 GB into an all-zero frame.
    path = tmp_path / "bomb.png"
    path.write_bytes(png_bytes(side, side))
    with pytest.raises(FileTooLargeError, match=rf"bomb.png declares {side} x {side} = .*MAX_FRAME_PIXELS"):
        read_depth_png(path)


@fast(30)
@given(width=st.integers(1, 2**31 - 1), height=st.integers(1, 2**31 - 1))
def test_any_declared_size_beyond_the_limit_is_refused(tmp_path_factory, width, height):
    path = tmp_path_factory.mktemp("bomb") / "x.png"
    path.write_bytes(png_bytes(width, height))
    if width * height > MAX_FRAME_PIXELS:
        with pytest.raises(FileTooLargeError, match="declares"):
            read_depth_png(path)
    else:  # within the limit: refused as truncated, or exactly the frame the zeros make
        try:
            depth = read_depth_png(path)
        except DepthFormatError as exc:
            assert "cannot decode" in str(exc)
        else:
            assert depth.shape == (height, width) and not depth.any()


def test_file_larger_than_its_frame_can_need_is_not_read(tmp_path):
    path = tmp_path / "padded.png"
    path.write_bytes(png_bytes(16, 8) + bytes(2 << 20))  # a 16x8 frame followed by 2 MiB
    with pytest.raises(OSError, match="padded.png is .* bytes, more than"):
        read_depth_png(path)


@pytest.mark.parametrize("ext, name", [(".tiff", "TIFF"), (".bmp", "BMP"), (".jpg", "JPEG")])
def test_other_formats_named_png_are_refused_by_reader_and_header_alike(tmp_path, ext, name):
    # OpenCV decodes a 16-bit TIFF named .png: evaluate accepted what info refused.
    image = np.full((8, 12), 700, np.uint16) if ext == ".tiff" else np.full((8, 12), 7, np.uint8)
    ok, buf = cv2.imencode(ext, image)
    assert ok
    path = tmp_path / "frame.png"
    path.write_bytes(buf.tobytes())
    for read in (read_depth_png, png_header):
        with pytest.raises(DepthFormatError, match=f"frame.png is an? {name} file, not a PNG"):
            read(path)


@pytest.mark.parametrize("color_type, bit_depth, match", [
    (4, 16, r"2 channels \(grey\+alpha\)"), (4, 8, r"2 channels \(grey\+alpha\)"), (6, 16, r"4 channels \(RGBA\)"),
    (2, 16, r"3 channels \(RGB\)"), (3, 8, "8-bit palette"), (0, 8, "8-bit PNG"),
])
def test_pixel_format_is_named_from_the_header(tmp_path, color_type, bit_depth, match):
    # Grey+alpha was called "4 channels" (what OpenCV decodes it to).
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[color_type]
    rows = b"".join(b"\x00" + bytes(4 * channels * bit_depth // 8) for _ in range(3))
    path = tmp_path / "fmt.png"
    path.write_bytes(png_bytes(4, 3, bit_depth=bit_depth, color_type=color_type, idat=zlib.compress(rows)))
    with pytest.raises(DepthFormatError, match=match):
        read_depth_png(path)


# -- files that cannot be read or written ------------------------------------------------------
def _deny(monkeypatch, path):
    """Make opening ``path`` fail as for a file without read permission (tests run as root, who may read anything)."""
    real_open = os.open

    def fake_open(file, *args, **kwargs):
        if os.fspath(file) == os.fspath(path):
            raise PermissionError(13, "Permission denied", os.fspath(file))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(os, "open", fake_open)


def test_permission_denied_is_said_with_the_path_not_called_corrupt(tmp_path, monkeypatch):
    path = tmp_path / "locked.png"
    write_depth_png(path, np.ones((8, 12)))
    if os.geteuid() != 0:
        path.chmod(0)
    else:
        _deny(monkeypatch, path)
    for read in (read_depth_png, png_header):
        with pytest.raises(PermissionError, match=f"permission denied reading depth PNG {path}$"):
            read(path)


def test_loop_of_symbolic_links_is_not_called_missing(tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    a.symlink_to(b)
    b.symlink_to(a)
    with pytest.raises(OSError, match=f"cannot read depth PNG {a}: a loop of symbolic links") as err:
        read_depth_png(a)
    assert not isinstance(err.value, FileNotFoundError)


def _full_disk(monkeypatch):
    """Make every flush to disk fail as on a full disk."""
    def no_space(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", no_space)


def test_full_disk_names_the_file_being_written(tmp_path, monkeypatch):
    path = tmp_path / "depth.png"
    write_depth_png(path, np.ones((8, 12)))
    _full_disk(monkeypatch)
    with pytest.raises(OSError, match=f"cannot write depth PNG {path}: No space left on device"):
        write_depth_png(path, np.full((8, 12), 2.0))
    monkeypatch.undo()
    np.testing.assert_array_equal(read_depth_png(path), 1.0)  # the previous file is intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["depth.png"]  # no temporary left


def test_a_link_at_the_target_is_replaced_never_written_through(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("mine")
    path = tmp_path / "depth.png"
    path.symlink_to(victim)
    write_depth_png(path, np.ones((8, 12)))
    assert victim.read_text() == "mine" and not path.is_symlink()


# -- names that are not UTF-8 --------------------------------------------------------------------
_NON_UTF8_SCRIPT = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    import numpy as np
    from inpaintenv.cli import main
    from inpaintenv.data.io import read_depth_png, write_depth_png

    base = Path(sys.argv[1])
    root = base / os.fsdecode(b"kitti-\\xff")                       # --kitti-root
    drive = os.fsdecode(b"2011_09_26_drive_\\xe9_sync")             # a drive name
    folder = root / "train" / drive / "proj_depth" / "groundtruth" / "image_02"
    rng = np.random.default_rng(0)
    for k in range(2):
        path = folder / os.fsdecode(b"%010d\\xfe.png" % k)         # a file name
        depth = (5 + 20 * rng.random((375, 1242))).astype(np.float32)
        write_depth_png(path, depth)
        assert np.array_equal(read_depth_png(path), np.round(depth * 256) / 256)
    out = base / os.fsdecode(b"out-\\xfd")                          # --out
    argv = ["--kitti-root", str(root), "--quiet"]
    assert main(["info", *argv]) == 0
    assert main(["evaluate", "-m", "constant", "--out", str(out / "ev"), *argv]) == 0
    assert "2011_09_26_drive_\\\\xe9_sync" in (out / "ev" / "results.csv").read_text()  # ids: \\xNN
    assert main(["show", "-m", "constant", "--out", str(out / "panel.png"), *argv]) == 0
    assert (out / "panel.png").read_bytes()[:4] == b"\\x89PNG"
    assert main(["benchmark", "-m", "constant", "--figure-frames", "0", "--out", str(out / "bench"), *argv]) == 0
    assert main(["export", "--out", str(out / "kit"), *argv]) == 0
    print("ok")
""")


def test_non_utf8_file_drive_root_and_out_names_in_a_subprocess(tmp_path):
    # OpenCV given such a path (surrogate escapes) crashed the process (exit 139): run in a
    # subprocess so that a crash fails this test instead of ending pytest.
    pytest.importorskip("estimators.classical")
    proc = subprocess.run([sys.executable, "-c", _NON_UTF8_SCRIPT, str(tmp_path)], capture_output=True, text=True,
                          errors="backslashreplace", timeout=300)
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])
    assert proc.stdout.strip().endswith("ok")


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_show_on_a_full_disk_says_so_instead_of_asking_for_a_png_name(tmp_path, capsys, monkeypatch):
    from inpaintenv.cli import main

    out = tmp_path / "panel.png"
    _full_disk(monkeypatch)
    assert main(["show", "--synthetic", "--n-frames", "1", "--frame-shape", "32", "48", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert f"cannot write panel {out}: No space left on device" in err and ".png name" not in err


# -- .npy / .npz headers and other PNGs (masks) --------------------------------------------------
def _npy_bomb(shape: tuple[int, ...]) -> bytes:
    """An .npy header declaring ``shape`` float32 values, followed by no data."""
    header = repr({"descr": "<f4", "fortran_order": False, "shape": shape}).encode()
    header += b" " * (118 - len(header)) + b"\n"
    return b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header


def test_npy_header_is_checked_before_loading(tmp_path):
    from inpaintenv.data.io import load_array

    bomb = tmp_path / "bomb.npy"
    bomb.write_bytes(_npy_bomb((100000, 100000)))  # 128 bytes declaring 40 GB
    with pytest.raises(FileTooLargeError, match=r"bomb.npy declares an array of shape \(100000, 100000\).*MAX_FRAME_PIXELS"):
        load_array(bomb)
    short = tmp_path / "short.npy"
    np.save(short, np.ones((4, 6), np.float32))
    short.write_bytes(short.read_bytes()[:-8])
    with pytest.raises(DepthFormatError, match=r"cannot read .*short.npy: truncated \(88 of 96 data bytes\)"):
        load_array(short)
    objects = tmp_path / "objects.npy"
    np.save(objects, np.array([1, "a"], dtype=object), allow_pickle=True)
    with pytest.raises(DepthFormatError, match="holds object values"):
        load_array(objects)
    with zipfile.ZipFile(tmp_path / "bomb.npz", "w") as z:
        z.writestr("depth.npy", _npy_bomb((60000, 60000)))
    with pytest.raises(FileTooLargeError, match=r"array 'depth' of .*bomb.npz declares an array of shape \(60000, 60000\)"):
        load_array(tmp_path / "bomb.npz")
    good = np.arange(12.0).reshape(3, 4)
    np.savez(tmp_path / "two.npz", depth=good, mask=good > 5)
    np.testing.assert_array_equal(load_array(tmp_path / "two.npz", key="depth"), good)
    with pytest.raises(DepthFormatError, match=r"holds the arrays \['depth', 'mask'\]"):
        load_array(tmp_path / "two.npz")
    np.save(tmp_path / "f.npy", np.asfortranarray(good))
    np.testing.assert_array_equal(load_array(tmp_path / "f.npy"), good)


@fast(30)
@given(data=st.binary(max_size=512))
def test_random_bytes_as_npy_are_refused_in_one_error(tmp_path_factory, data):
    from inpaintenv.data.io import load_array

    path = tmp_path_factory.mktemp("npy") / "x.npy"
    path.write_bytes(b"\x93NUMPY" + data)
    try:
        arr = load_array(path)
    except (DepthFormatError, FileTooLargeError):
        return
    assert arr.size <= MAX_FRAME_PIXELS


def test_read_png_checks_signature_and_size_but_not_the_pixel_format(tmp_path):
    from inpaintenv.data.io import read_png

    mask = tmp_path / "mask.png"
    mask.write_bytes(cv2.imencode(".png", np.full((4, 5, 3), 255, np.uint8))[1].tobytes())
    assert read_png(mask).shape == (4, 5, 3)
    (tmp_path / "bomb.png").write_bytes(png_bytes(60000, 60000, bit_depth=8))
    with pytest.raises(FileTooLargeError, match="declares 60000 x 60000"):
        read_png(tmp_path / "bomb.png")
    tiff = tmp_path / "t.png"
    tiff.write_bytes(cv2.imencode(".tiff", np.ones((4, 5), np.uint8))[1].tobytes())
    with pytest.raises(DepthFormatError, match="is a TIFF file, not a PNG"):
        read_png(tiff)


def _npz_bytes() -> bytes:
    import io

    buf = io.BytesIO()
    np.savez_compressed(buf, depth=np.linspace(1, 80, 96, dtype=np.float32).reshape(8, 12))
    return buf.getvalue()


@fast(60)
@given(flips=st.lists(st.tuples(st.integers(0, 10_000), st.integers(1, 255)), min_size=1, max_size=4),
       cut=st.one_of(st.none(), st.integers(0, 10_000)))
def test_damaged_npz_files_are_refused_in_one_error(tmp_path_factory, flips, cut):
    # Byte flips and truncation anywhere (ZIP headers, the directory, the deflate stream, the .npy header).
    from inpaintenv.data.io import load_array

    data = bytearray(_npz_bytes())
    for at, xor in flips:
        data[at % len(data)] ^= xor
    path = tmp_path_factory.mktemp("npz") / "x.npz"
    path.write_bytes(bytes(data if cut is None else data[:cut % len(data)]))
    try:
        arr = load_array(path, key=("depth",))
    except (DepthFormatError, FileTooLargeError):
        return
    assert arr.size <= MAX_FRAME_PIXELS
