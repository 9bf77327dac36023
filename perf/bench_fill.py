"""Throughput of ``inpaintenv fill`` on a folder of KITTI-sized PNGs against the in-process ``predict`` loop.

Writes ``--frames`` 16-bit depth PNGs (the built-in synthetic streets at KITTI's 352x1216, or the first
frames of a KITTI split with ``--kitti-root``: single-scan ``velodyne_raw`` maps) and one ``rect-v1`` hole
mask per frame to a temporary folder, then for each method times

* **predict**: the frames and masks already in memory, ``predict`` on batches of ``--batch-size`` (what a
  Python loop over arrays costs: no decoding, no encoding, no files);
* **serial**: the loop one writes by hand (read a batch of PNGs and masks, ``predict``, write), one thread;
* **fill**: :func:`inpaintenv.filling.fill` on the folder (read, mask, predict, encode, write atomically;
  reading ahead and writing behind in two threads), with the same already-built method, so the model's
  loading time is in neither figure.

The overhead is fill's wall time over predict's (the median over ``--repeat`` interleaved runs of the
three); the CPU time of all threads per frame says how much work reading and writing add, which the
threads can hide only where a core is free.
Examples::

    python perf/bench_fill.py                                  # 100 synthetic frames, pretrained + scanline
    python perf/bench_fill.py --frames 20 --method pretrained  # fewer frames on a busy machine
    python perf/bench_fill.py --kitti-root <KITTI root> --json fill.json
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from inpaintenv.data import KittiDepth, SyntheticStreets, write_depth_png
from inpaintenv.data.io import write_png
from inpaintenv.files import write_json
from inpaintenv.filling import fill
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method


def write_folder(folder: Path, frames: int, kitti_root: str | None) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``depth/NNNN.png`` and ``masks/NNNN.png`` under ``folder``; returns the depth maps and masks as read back."""
    from inpaintenv.data import read_depth_png

    source = (KittiDepth(kitti_root, kind="velodyne_raw") if kitti_root
              else SyntheticStreets(n=frames, kind="velodyne_raw", seed=0))
    if len(source) < frames:
        raise SystemExit(f"the source has {len(source)} frames, fewer than --frames {frames}")
    proto = get_protocol("rect-v1")
    depths, masks = [], []
    for i in range(frames):
        gt = np.asarray(source[i], dtype=np.float32)
        hole = proto.mask(gt.shape, 0, i)
        write_depth_png(folder / "depth" / f"{i:04d}.png", gt)
        (folder / "masks").mkdir(parents=True, exist_ok=True)
        write_png(folder / "masks" / f"{i:04d}.png", hole.astype(np.uint8) * 255, "mask PNG")
        depths.append(read_depth_png(folder / "depth" / f"{i:04d}.png"))
        masks.append(hole)
    return depths, masks


class Clock:
    """Wall and CPU seconds (all threads of the process) of a ``with`` block."""

    def __enter__(self) -> "Clock":
        self.wall, self.cpu = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc: object) -> None:
        self.wall, self.cpu = time.perf_counter() - self.wall, time.process_time() - self.cpu


def time_predict(method, depths: list[np.ndarray], masks: list[np.ndarray], batch_size: int) -> Clock:
    """``predict`` over the frames in memory, in batches (inputs built outside the clock)."""
    inputs = [np.where(m, np.float32(np.nan), d) for d, m in zip(depths, masks)]
    batches = [np.stack(inputs[i:i + batch_size]) for i in range(0, len(inputs), batch_size)]
    method.predict(batches[0][:1])  # warm-up, as fill's first batch is not warmed
    with Clock() as clock:
        for batch in batches:
            method.predict(batch)
    return clock


def time_serial(method, folder: Path, out: Path, batch_size: int) -> Clock:
    """The loop a user writes by hand: read a batch, predict, write, one thread."""
    from inpaintenv.data import read_depth_file, read_mask_file, write_depth_file

    names = sorted(p.name for p in (folder / "depth").iterdir())
    with Clock() as clock:
        for i in range(0, len(names), batch_size):
            depths = [read_depth_file(folder / "depth" / n) for n in names[i:i + batch_size]]
            masks = [read_mask_file(folder / "masks" / n) for n in names[i:i + batch_size]]
            pred = method.predict(np.stack([np.where(m, np.float32(np.nan), d) for d, m in zip(depths, masks)]))
            for n, d, m, p in zip(names[i:i + batch_size], depths, masks, pred):
                write_depth_file(out / n, np.where(m, p, d))
    return clock


def time_fill(method, folder: Path, out: Path, batch_size: int) -> Clock:
    """:func:`fill` on the folder (after one warm-up frame into another folder)."""
    fill([sorted((folder / "depth").iterdir())[0]], folder / "warm", method=method, holes=folder / "masks" / "0000.png",
         batch_size=batch_size, progress=False)
    with Clock() as clock:
        report = fill(folder / "depth", out, method=method, holes=folder / "masks", batch_size=batch_size,
                      progress=False)
    if not report.ok or len(report.written) != len(list((folder / "depth").iterdir())):
        raise SystemExit(f"fill did not write every frame: {report.summary()}")
    return clock


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=100, help="PNGs in the folder (default 100)")
    p.add_argument("--method", action="append", help="method name (repeatable; default pretrained and scanline)")
    p.add_argument("--batch-size", type=int, default=4, help="frames per predict call, in both loops (default 4)")
    p.add_argument("--repeat", type=int, default=1, help="runs of each loop; the best is kept (default 1)")
    p.add_argument("--kitti-root", help="real velodyne_raw frames of a KITTI split instead of synthetic ones")
    p.add_argument("--json", help="also write the results here")
    args = p.parse_args(argv)
    if args.frames < 1 or args.batch_size < 1 or args.repeat < 1:
        p.error("--frames, --batch-size and --repeat must be >= 1")
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-fill-") as tmp:
        folder = Path(tmp)
        depths, masks = write_folder(folder, args.frames, args.kitti_root)
        for name in args.method or ["pretrained", "scanline"]:
            method = make_method(name)
            runs = []
            for k in range(args.repeat):  # interleaved, so that a change of the machine's load hits all three
                runs.append((time_predict(method, depths, masks, args.batch_size),
                             time_serial(method, folder, folder / f"serial-{name}-{k}", args.batch_size),
                             time_fill(method, folder, folder / f"out-{name}-{k}", args.batch_size)))
            predict_s, serial_s, fill_s = (min(r[j].wall for r in runs) for j in range(3))
            cpu_ms = [1000 * min(r[j].cpu for r in runs) / args.frames for j in range(3)]
            overhead = statistics.median(100 * (f.wall / p.wall - 1) for p, _, f in runs)
            serial_overhead = statistics.median(100 * (s.wall / p.wall - 1) for p, s, _ in runs)
            rows.append({"method": name, "frames": args.frames, "repeat": args.repeat,
                         "predict_s": round(predict_s, 3), "serial_s": round(serial_s, 3), "fill_s": round(fill_s, 3),
                         "fill_fps": round(args.frames / fill_s, 2), "overhead_pct": round(overhead, 1),
                         "serial_overhead_pct": round(serial_overhead, 1),
                         "cpu_ms_per_frame": dict(zip(("predict", "serial", "fill"), (round(c, 1) for c in cpu_ms)))})
            print(f"{name}: {args.frames} frames of {depths[0].shape[1]}x{depths[0].shape[0]}, best of {args.repeat}: "
                  f"predict {predict_s:.2f} s, serial file loop {serial_s:.2f} s, fill {fill_s:.2f} s "
                  f"({rows[-1]['fill_fps']} frames/s); overhead over predict (median of the runs): fill "
                  f"{overhead:+.1f} %, serial loop {serial_overhead:+.1f} %; CPU ms/frame (all threads): predict "
                  f"{cpu_ms[0]:.1f}, serial {cpu_ms[1]:.1f}, fill {cpu_ms[2]:.1f}")
    out = {"frame": list(depths[0].shape), "batch_size": args.batch_size, "rows": rows}
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    main()
