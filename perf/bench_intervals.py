"""Cost of ConformalIntervalInpainter's std/interval against the base's plain predict.

Times ``predict(X)`` and ``predict(X, return_std=True)`` (and ``predict_interval``) of the
wrapper around a registered method (default: the learned default, ``pretrained``) on a
few frames, interleaved and repeated, and prints the median ratio. The issue's bound is
``return_std`` <= 1.3x ``predict``.

    python perf/bench_intervals.py --kitti-root /path/to/kitti [--method pretrained] [--frames 4]

Without ``--kitti-root`` the frames are synthetic streets at KITTI's crop (say so when
quoting). The wrapper is calibrated on synthetic frames only to have a calibration to
time: the cost does not depend on what it was calibrated on (the shipped release saw
every KITTI drive of this slice, so none can calibrate it honestly).
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any, Callable

import numpy as np


def _inputs(root: str | None, n: int) -> tuple[np.ndarray, str]:
    from estimators.base import iter_scoring_batches
    from inpaintenv.data import KittiDepth, SyntheticStreets

    if root:
        ds = KittiDepth(root, split="train")
        frames, what = ds[np.linspace(0, len(ds) - 1, n).astype(int)], f"{n} real KITTI frames (train, rect-v1 holes)"
    else:
        frames, what = SyntheticStreets(n=n, seed=1), f"{n} synthetic frames (352x1216, rect-v1 holes)"
    x, _, _ = next(iter_scoring_batches(frames, chunk=n, seed=0))
    return x, what


def _median_seconds(call: Callable[[], Any], repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        out.append(time.perf_counter() - start)
    return out


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root")
    parser.add_argument("--method", default="pretrained")
    parser.add_argument("--spread-method", default="scanline")
    parser.add_argument("--frames", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)

    from estimators.intervals import ConformalIntervalInpainter
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.methods.registry import make_method

    base = make_method(args.method)
    cal = SyntheticStreets(n=4, seed=0)
    wrapper = ConformalIntervalInpainter(base, spread_method=args.spread_method).fit(
        cal, groups=[f"synthetic-{k}" for k in range(len(cal))])
    x, what = _inputs(args.kitti_root, args.frames)
    wrapper.predict(x)
    wrapper.predict(x, return_std=True)  # warm-up: torch's first call, lazy loads
    plain, std, interval = [], [], []
    for _ in range(args.repeats):  # interleaved, so a load change on the machine hits all three
        plain += _median_seconds(lambda: wrapper.predict(x), 1)
        std += _median_seconds(lambda: wrapper.predict(x, return_std=True), 1)
        interval += _median_seconds(lambda: wrapper.predict_interval(x), 1)
    per = {k: statistics.median(v) / len(x) * 1000 for k, v in
           (("predict_ms", plain), ("return_std_ms", std), ("predict_interval_ms", interval))}
    per["ratio_std"] = per["return_std_ms"] / per["predict_ms"]
    per["ratio_interval"] = per["predict_interval_ms"] / per["predict_ms"]
    print(f"{args.method} wrapped (spread vs {args.spread_method}), {what}, median of {args.repeats}:")
    print(f"  predict                    {per['predict_ms']:8.1f} ms/frame")
    print(f"  predict(return_std=True)   {per['return_std_ms']:8.1f} ms/frame  ({per['ratio_std']:.2f}x)")
    print(f"  predict_interval           {per['predict_interval_ms']:8.1f} ms/frame  ({per['ratio_interval']:.2f}x)")
    return per


if __name__ == "__main__":
    main()
