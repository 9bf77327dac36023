"""Training and inference speed of the U-Net inpainter at KITTI resolution.

Measures, on in-memory synthetic input (so PNG decoding is not part of the figure):

* training: frames/s of full optimiser steps (forward, loss, backward, Adam) at batch
  ``--batch`` -- the path of ``UNetInpainter.fit`` (``_train_step``);
* inference: ms/frame of ``UNetInpainter``'s batched ``torch.inference_mode`` forward.

Examples
--------
    python perf/bench_neural.py                          # fp32, CPU
    python perf/bench_neural.py --channels-last
    python perf/bench_neural.py --amp cpu-bf16
    python perf/bench_neural.py --compile default        # torch.compile (inductor)
    python perf/bench_neural.py --device cuda --amp true --channels-last   # on a GPU

Timing uses the median over ``--steps`` repetitions after one warm-up step; with
``--compile`` the warm-up step includes the compilation, reported separately.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import numpy as np
import torch

from estimators.learned import UNetInpainter
from inpaintenv.masks import get_protocol


def _amp(value: str) -> bool | str:
    return {"true": True, "false": False, "cpu-bf16": "cpu-bf16"}[value.lower()]


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize()


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--height", type=int, default=352)
    p.add_argument("--width-px", type=int, default=1216)
    p.add_argument("--net-width", type=int, default=32)
    p.add_argument("--net-depth", type=int, default=4)
    p.add_argument("--batch", type=int, default=4)
    p.add_argument("--steps", type=int, default=3, help="timed repetitions (after 1 warm-up)")
    p.add_argument("--device", default="cpu")
    p.add_argument("--amp", type=_amp, default=False, help="true | false | cpu-bf16")
    p.add_argument("--channels-last", action="store_true")
    p.add_argument("--threads", type=int, default=None, help="torch.set_num_threads")
    p.add_argument("--input-mask", action="store_true")
    p.add_argument("--compile", default="none",
                   help="none | default | reduce-overhead | max-autotune (torch.compile mode)")
    args = p.parse_args(argv)

    est = UNetInpainter(
        width=args.net_width, depth=args.net_depth, batch_size=args.batch, device=args.device,
        amp=args.amp, channels_last=args.channels_last, num_threads=args.threads,
        input_mask=args.input_mask,
        compile={"none": False, "default": True}.get(args.compile, args.compile),
    )
    est._check_params()
    if args.threads is not None:
        torch.set_num_threads(args.threads)
    device = est._device()
    shape = (args.height, args.width_px)
    rng = np.random.default_rng(0)
    gt = (rng.uniform(2.0, 80.0, (args.batch, *shape)) * (rng.random((args.batch, *shape)) < 0.3)).astype(np.float32)
    hole = get_protocol("rect-v1").masks(shape, 0, range(args.batch))

    model = est._build_model(0).to(device)
    if args.channels_last:
        model = model.to(memory_format=torch.channels_last)
    optimisation = est._prepare_training(model, device)  # Adam, schedule and precision as fit builds them
    gt_t, hole_t = torch.from_numpy(gt), torch.from_numpy(hole)
    if device.type == "cuda":
        gt_t, hole_t = gt_t.pin_memory(), hole_t.pin_memory()

    step_model = est._compiled(model)
    train_times, warmups = [], {}
    model.train()
    for i in range(args.steps + 1):
        _sync(device)
        t0 = time.perf_counter()
        est._train_step(step_model, optimisation, gt_t, hole_t, device)
        _sync(device)
        if i:
            train_times.append(time.perf_counter() - t0)
        else:
            warmups["train_warmup_s"] = round(time.perf_counter() - t0, 2)

    x = np.where(hole, np.nan, gt).astype(np.float32)
    infer_times = []
    for i in range(args.steps + 1):
        _sync(device)
        t0 = time.perf_counter()
        est._forward(step_model, x, device)
        _sync(device)
        if i:
            infer_times.append(time.perf_counter() - t0)
        else:
            warmups["infer_warmup_s"] = round(time.perf_counter() - t0, 2)

    step = statistics.median(train_times)
    infer = statistics.median(infer_times)
    result = {
        "device": str(device),
        "torch": torch.__version__,
        "threads": torch.get_num_threads(),
        "cpu": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "load_avg_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "frame": list(shape),
        "net": {"width": args.net_width, "depth": args.net_depth, "input_mask": args.input_mask},
        "batch": args.batch,
        "amp": args.amp,
        "channels_last": args.channels_last,
        "compile": args.compile,
        **warmups,
        "train_s_per_step": round(step, 3),
        "train_frames_per_s": round(args.batch / step, 3),
        "infer_ms_per_frame": round(1000 * infer / args.batch, 1),
    }
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
