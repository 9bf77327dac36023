"""How training and inference cost of the study's U-Net grows with width, depth and resolution.

For each configuration the script builds ``estimators.learned.nets.UNet(1, width, depth,
skip=True)`` and times, on synthetic in-memory input (so data loading is not part of it):

* **one training step** exactly as ``UNetInpainter._train_step`` does it with the
  defaults (fp32, CPU, ``depth_scale="fixed"``, 1 input channel): network input
  ``encode_input(gt with holes zeroed) = depth / 80``, forward,
  ``inpainting_loss(pred, gt / 80, gt > 0, hole, 2.0, 0.01)``, backward, Adam step
  (lr 1e-3, weight decay 1e-6), at batch ``--batch``;
* **inference of one frame** as ``UNetInpainter._forward`` does it on CPU (one frame per
  call, ``torch.inference_mode``, eval mode).

Times are the best of ``--repeats`` after one warm-up, with ``torch.set_num_threads``
(default 1). Both the CPU time of this process (``time.process_time``; the primary
figure, steadier on a shared machine) and wall time are recorded.

FLOPs are counted exactly with ``torch.utils.flop_counter.FlopCounterMode`` on the meta
device (no arithmetic is run, so any resolution is free to count). The counter counts
the matrix-multiply-like operators -- here every convolution and its two backward
products, 2 FLOPs per multiply-add, biases excluded -- and nothing else (GroupNorm,
ReLU, pooling, interpolation, loss, Adam are uncounted). ``_unet_flops.unet_conv_flops`` gives
the same number from the architecture alone.

Fits (ordinary least squares): CPU seconds against GFLOPs (s/GFLOP, R²), against
megapixels, and ``log time`` against ``log width`` / ``log GFLOPs`` (the exponent).
Finally the FLOPs of the study's recipes on full KITTI (85,898 train frames at
352×1216) and the measured CPU s/GFLOP extrapolation to them.

Examples
--------
    python perf/scaling_training.py                       # ~10 min, 1 thread
    python perf/scaling_training.py --quick               # ~1 min
    python perf/scaling_training.py --json scaling_training.json
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from _unet_flops import forward_flops, n_params, train_flops, unet_level_flops

from estimators.learned._training_data import encode_input
from estimators.learned.losses import inpainting_loss
from estimators.learned.nets import UNet
from inpaintenv.files import read_json, write_json
from inpaintenv.masks import get_protocol

#: Defaults of the study's estimators (``estimators.learned._neural``): normalisation, loss, Adam.
MAX_DEPTH = 80.0
HOLE_WEIGHT = 2.0
TV_WEIGHT = 0.01
LR = 1e-3
WEIGHT_DECAY = 1e-6

#: KITTI depth completion train split, frames, and the bottom-centre crop every loader uses.
KITTI_TRAIN_FRAMES = 85_898
KITTI_CROP = (352, 1216)


# -- timing --------------------------------------------------------------------------
def make_batch(batch: int, height: int, width_px: int, seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    """Synthetic ground truth (25 % of pixels measured, 2-80 m) and rect-v1 holes."""
    rng = np.random.default_rng(seed)
    gt = rng.uniform(2.0, 80.0, (batch, height, width_px)).astype(np.float32)
    gt[rng.random(gt.shape) > 0.25] = 0.0
    hole = get_protocol("rect-v1").masks((height, width_px), seed, range(batch))
    return torch.from_numpy(gt), torch.from_numpy(np.ascontiguousarray(hole))


def make_train_step(model: UNet, gt: torch.Tensor, hole: torch.Tensor) -> Callable[[], float]:
    """One optimiser step as ``UNetInpainter._train_step`` (fp32, CPU, no scaler)."""
    optimizer = torch.optim.Adam(model.parameters(), lr=LR, weight_decay=WEIGHT_DECAY)
    model.train()

    def step() -> float:
        target = gt / MAX_DEPTH
        x = encode_input(torch.where(hole, torch.zeros_like(gt), gt), hole, MAX_DEPTH, False)
        optimizer.zero_grad(set_to_none=True)
        pred = model(x)[:, 0]
        loss = inpainting_loss(pred.float(), target, gt > 0, hole, HOLE_WEIGHT, TV_WEIGHT)
        loss.backward()
        optimizer.step()
        return float(loss.detach())

    return step


def make_inference(model: UNet, gt: torch.Tensor, hole: torch.Tensor) -> Callable[[], None]:
    """One frame through the network as ``UNetInpainter._forward`` does on CPU."""
    depth = torch.where(hole[:1], torch.zeros_like(gt[:1]), gt[:1])

    def infer() -> None:
        model.eval()
        with torch.inference_mode():
            x = encode_input(depth, hole[:1], MAX_DEPTH, False)
            (model(x)[:, 0] * MAX_DEPTH).numpy()

    return infer


def time_call(fn: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """Best CPU seconds (this process) and best wall seconds of ``repeats`` calls after a warm-up."""
    fn()
    cpu, wall = math.inf, math.inf
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        cpu, wall = min(cpu, time.process_time() - c0), min(wall, time.perf_counter() - w0)
    return cpu, wall


def measure(width: int, depth: int, height: int, width_px: int, batch: int, repeats: int,
            train: bool = True) -> dict[str, Any]:
    """Time and count one configuration; ``train=False`` skips the training step."""
    torch.manual_seed(0)
    model = UNet(1, width, depth, skip=True)
    gt, hole = make_batch(batch, height, width_px)
    row: dict[str, Any] = {
        "width": width, "depth": depth, "height": height, "width_px": width_px, "batch": batch,
        "megapixels": height * width_px / 1e6, "params": n_params(width, depth),
        "fwd_gflop_frame": forward_flops(width, depth, height, width_px) / 1e9,
        "train_gflop_frame": train_flops(width, depth, height, width_px) / 1e9,
    }
    row["infer_cpu_s"], row["infer_wall_s"] = time_call(make_inference(model, gt, hole), repeats)
    if train:
        cpu, wall = time_call(make_train_step(model, gt, hole), repeats)
        row["train_cpu_s_step"], row["train_wall_s_step"] = cpu, wall
        row["train_cpu_s_frame"] = cpu / batch
    return row


# -- fits ----------------------------------------------------------------------------
def fit_line(x: Any, y: Any, through_origin: bool = False) -> dict[str, float]:
    """Least squares ``y = a + b x`` (or ``y = b x``) with R² (about the mean of ``y``)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 2:
        raise ValueError(f"a fit needs at least 2 points, got {len(x)}")
    if through_origin:
        b, a = float(x @ y / (x @ x)), 0.0
    else:
        b, a = (float(v) for v in np.polyfit(x, y, 1))
    resid = y - (a + b * x)
    ss_tot = float(((y - y.mean()) ** 2).sum())
    r2 = 1.0 - float((resid**2).sum()) / ss_tot if ss_tot > 0 else float("nan")
    return {"a": a, "b": b, "r2": r2}


def fit_power(x: Any, y: Any) -> dict[str, float]:
    """Exponent ``k`` of ``y ∝ x^k``: a line through ``(log x, log y)``."""
    f = fit_line(np.log(x), np.log(y))
    return {"k": f["b"], "log_c": f["a"], "r2": f["r2"]}


# -- report --------------------------------------------------------------------------
def _table(rows: list[dict[str, Any]], key: str, label: Callable[[dict], str]) -> str:
    lines = [
        (f"| {key} | params | fwd GFLOP/frame | train GFLOP/frame | train CPU s/step (wall) "
        "| train CPU s/frame | train ms/GFLOP | infer CPU s/frame (wall) | infer ms/GFLOP |"),
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if "train_cpu_s_step" in r:
            tr = f"{r['train_cpu_s_step']:.3f} ({r['train_wall_s_step']:.3f})"
            trf = f"{r['train_cpu_s_frame']:.3f} | {1e3 * r['train_cpu_s_frame'] / r['train_gflop_frame']:.1f}"
        else:
            tr, trf = "not run", "– | –"
        lines.append(
            f"| {label(r)} | {r['params']:,} | {r['fwd_gflop_frame']:.2f} | {r['train_gflop_frame']:.2f} "
            f"| {tr} | {trf} | {r['infer_cpu_s']:.3f} ({r['infer_wall_s']:.3f}) "
            f"| {1e3 * r['infer_cpu_s'] / r['fwd_gflop_frame']:.1f} |"
        )
    return "\n".join(lines)


def _uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True, check=False).stdout.strip()
    except OSError:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())


def kitti_costs(rates: dict[str, tuple[float, float]], frames: int = KITTI_TRAIN_FRAMES) -> list[dict]:
    """FLOPs of the study's recipes on full KITTI and their CPU extrapolation.

    Recipes (``estimators.learned.presets``): one epoch of the full-frame U-Net (width 32, depth
    4, the GPU-sized ``study`` preset) and of the CPU presets' U-Net (width 16), and the
    whole two-stage ``study`` recipe -- autoencoder on 25 % of the frames, then U-Net on
    50 %, 20 epochs each, 10 % of each subset held out for a validation pass per epoch.
    ``rates`` maps a name to (training, inference) CPU s/GFLOP; for each, the CPU
    core-hours ``train FLOPs × training rate + inference FLOPs × inference rate``.
    """
    h, w = KITTI_CROP
    out = []
    for name, width in (("U-Net w32 d4 (preset `study`, stage 2), 1 epoch", 32),
                        ("U-Net w16 d4 (CPU presets' network), 1 epoch", 16)):
        out.append({"recipe": name, "train_frames": frames, "infer_frames": 0,
                        "train_flops": train_flops(width, 4, h, w) * frames, "infer_flops": 0})
    # Two-stage study recipe (STAGED_PRESETS["study"]).
    rec = {"recipe": "whole `study` recipe (AE 25 % + U-Net 50 %, 20 epochs each, 10 % val)",
               "train_frames": 0, "infer_frames": 0, "train_flops": 0, "infer_flops": 0}
    for skip, fraction in ((False, 0.25), (True, 0.5)):
        n = round(frames * fraction)
        n_val = round(n * 0.1)
        tr, inf = (n - n_val) * 20, n_val * 20
        rec["train_frames"] += tr
        rec["infer_frames"] += inf
        rec["train_flops"] += tr * train_flops(32, 4, h, w, skip=skip)
        rec["infer_flops"] += inf * forward_flops(32, 4, h, w, skip=skip)
    out.append(rec)
    for r in out:
        r["flops"] = r["train_flops"] + r["infer_flops"]
        r["cpu_core_hours"] = {name: (r["train_flops"] * tr + r["infer_flops"] * inf) / 1e9 / 3600
                               for name, (tr, inf) in rates.items()}
    return out


def gpu_estimate(flops: float, frame_train_flops: float, params: int, batch: int, peak_tflops: float,
                 utils: tuple[float, float], ddp_eff: tuple[float, float], link_gbps: tuple[float, float],
                 loader_ms: dict[str, float]) -> dict[str, Any]:
    """ASSUMED GPU cost of ``flops``, derived only from the assumptions passed in.

    1 GPU: ``flops / (peak × utilisation)``; 8 GPUs: that ``/ (8 × DDP efficiency)``.
    Each pair is (optimistic, pessimistic). Also, for a network costing
    ``frame_train_flops`` per training frame: the step time at ``batch`` frames per GPU,
    the ring all-reduce time of its fp32 gradients (``2 (n-1)/n × 4 × params`` bytes per
    GPU, n = 8) over the assumed link bandwidths, the training frames/s that 8 GPUs
    consume and the loader cores that takes at each given CPU ms/frame.
    """
    hi_util, lo_util = max(utils), min(utils)
    one = [flops / (peak_tflops * 1e12 * u) / 3600 for u in (hi_util, lo_util)]
    eight = [one[0] / (8 * max(ddp_eff)), one[1] / (8 * min(ddp_eff))]
    step_s = [batch * frame_train_flops / (peak_tflops * 1e12 * u) for u in (hi_util, lo_util)]
    grad_bytes = 4 * params
    allreduce_ms = [2 * 7 / 8 * grad_bytes / (g * 1e9) * 1e3 for g in (max(link_gbps), min(link_gbps))]
    fps8 = [8 * e * batch / t for e, t in zip((max(ddp_eff), min(ddp_eff)), step_s)]
    cores = {name: [f * ms / 1e3 for f in fps8] for name, ms in loader_ms.items()}
    return {"one_gpu_h": one, "eight_gpu_h": eight, "step_s": step_s, "batch": batch,
                "grad_mbytes": grad_bytes / 1e6, "allreduce_ms": allreduce_ms,
                "frames_per_s_8gpu": fps8, "loader_cores_8gpu": cores}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="small sweep (~1 min): fewer, smaller points")
    p.add_argument("--batch", type=int, default=4, help="training batch (the study's 4)")
    p.add_argument("--repeats", type=int, default=2, help="timed repetitions after one warm-up")
    p.add_argument("--threads", type=int, default=1, help="torch.set_num_threads")
    p.add_argument("--max-train-mp", type=float, default=0.5,
                   help="skip the training step above this many megapixels (inference only)")
    p.add_argument("--gpu-peak-tflops", type=float, default=312.0,
                   help="ASSUMED peak dense bf16 TFLOP/s of one GPU (A100: 312)")
    p.add_argument("--gpu-util", type=float, nargs=2, default=(0.15, 0.40),
                   help="ASSUMED sustained fraction of peak, low and high")
    p.add_argument("--ddp-eff", type=float, nargs=2, default=(0.85, 0.95),
                   help="ASSUMED 8-GPU DDP scaling efficiency, low and high")
    p.add_argument("--link-gbps", type=float, nargs=2, default=(20.0, 200.0),
                   help="ASSUMED all-reduce bandwidth per GPU, GB/s: PCIe-class and NVLink-class")
    p.add_argument("--load-ms", type=float, nargs=2, default=(5.37, 0.63),
                   help="CPU ms per training frame of the loader: KittiDepth decode + mask, and "
                        "CachedDataset + mask (from perf/profile_pipeline.py)")
    p.add_argument("--from-json", default=None,
                   help="reuse the measurements of an earlier --json file; only redo fits and projections")
    p.add_argument("--json", default=None, help="write all numbers to this JSON file")
    args = p.parse_args(argv)
    for name in ("batch", "repeats", "threads"):
        if getattr(args, name) < 1:
            p.error(f"--{name} must be >= 1, got {getattr(args, name)}")
    for name in ("gpu_util", "ddp_eff"):
        if not all(0 < v <= 1 for v in getattr(args, name)):
            p.error(f"--{name.replace('_', '-')} values must be in (0, 1], got {getattr(args, name)}")

    if args.from_json:
        old = read_json(args.from_json, "--from-json file")
        info, sweeps = old["info"], old["sweeps"]
    else:
        info, sweeps = _run_sweeps(args, argv)
    all_rows = list({(r["width"], r["depth"], r["height"], r["width_px"]): r
                     for rows in sweeps.values() for r in rows}.values())
    fits = _fits(sweeps, all_rows)

    h, w = KITTI_CROP
    rates = {"fit": (fits["train_s_per_gflop"]["b"], fits["infer_s_per_gflop"]["b"])}
    full_rows = [r for r in all_rows if (r["width"], r["depth"], r["height"], r["width_px"]) == (32, 4, h, w)
                 and "train_cpu_s_step" in r]
    if full_rows:  # measured at exactly KITTI's frame size: the better rate for KITTI
        r = full_rows[0]
        rates["352x1216"] = (r["train_cpu_s_frame"] / r["train_gflop_frame"], r["infer_cpu_s"] / r["fwd_gflop_frame"])
    kitti = kitti_costs(rates)
    full = {"fwd_gflop_frame": forward_flops(32, 4, h, w) / 1e9, "train_gflop_frame": train_flops(32, 4, h, w) / 1e9,
                "fwd_gflop_frame_w16": forward_flops(16, 4, h, w) / 1e9,
                "train_gflop_frame_w16": train_flops(16, 4, h, w) / 1e9,
                "fwd_gflop_frame_ae": forward_flops(32, 4, h, w, skip=False) / 1e9,
                "train_gflop_frame_ae": train_flops(32, 4, h, w, skip=False) / 1e9,
                "level_share_w32": [round(f / sum(lv), 3) for lv in [unet_level_flops(32, 4, h, w)] for f in lv],
                "params_w32": n_params(32, 4), "params_w16": n_params(16, 4), "params_ae_w32": n_params(32, 4, skip=False)}
    loader = {"KittiDepth": args.load_ms[0], "CachedDataset": args.load_ms[1]}
    gpu = []
    for r, (width, skip) in zip(kitti, ((32, True), (16, True), (32, True))):
        gpu.append(dict(recipe=r["recipe"], **gpu_estimate(
            r["flops"], train_flops(width, 4, h, w, skip=skip), n_params(width, 4, skip), args.batch,
            args.gpu_peak_tflops, tuple(args.gpu_util), tuple(args.ddp_eff), tuple(args.link_gbps), loader)))

    print_report(info, sweeps, fits, full, rates, kitti, gpu, args)
    out = {"info": info, "sweeps": sweeps, "fits": fits, "full_frame": full, "kitti": kitti, "gpu": gpu,
               "assumptions": {"gpu_peak_tflops": args.gpu_peak_tflops, "gpu_util": list(args.gpu_util),
                                "ddp_eff": list(args.ddp_eff), "link_gbps": list(args.link_gbps),
                                "load_ms": loader}, "cpu_rates": rates}
    if args.json:
        write_json(args.json, out)
    return out


def print_report(info: dict, sweeps: dict[str, list[dict]], fits: dict[str, dict[str, float]], full: dict,
                 rates: dict[str, tuple[float, float]], kitti: list[dict], gpu: list[dict],
                 args: argparse.Namespace) -> None:
    """The sweeps' tables, the fits, the full-frame costs and the full-KITTI projections, as printed."""
    base = sweeps["width"][0]
    h, w = KITTI_CROP
    print(f"\n## Width (depth {base['depth']}, {base['height']}×{base['width_px']}, batch {info['batch']})\n")
    print(_table(sweeps["width"], "width", lambda r: str(r["width"])))
    print(f"\n## Resolution (width {sweeps['resolution'][0]['width']})\n")
    print(_table(sweeps["resolution"], "crop (MP)", lambda r: f"{r['height']}×{r['width_px']} ({r['megapixels']:.3f})"))
    print(f"\n## Depth (width {sweeps['depth'][0]['width']}, {base['height']}×{base['width_px']})\n")
    print(_table(sweeps["depth"], "depth", lambda r: str(r["depth"])))
    print("\n## Fits (CPU seconds)\n")
    for k, f in fits.items():
        print(f"  {k}: " + ", ".join(f"{n}={v:.4g}" for n, v in f.items()))
    print("\n## Full 352×1216 frames\n")
    for k, v in full.items():
        print(f"  {k}: {v:,.3f}" if isinstance(v, float) else f"  {k}: {v:,}" if isinstance(v, int) else f"  {k}: {v}")
    print(f"\n## Full KITTI ({KITTI_TRAIN_FRAMES:,} train frames at {h}×{w})")
    print("CPU rates (train, inference ms/GFLOP; measured, " + f"{info['threads']} thread(s)): "
          + "; ".join(f"{n} {tr * 1e3:.2f}, {inf * 1e3:.2f}" for n, (tr, inf) in rates.items()))
    print(f"GPU: ESTIMATE FROM ASSUMPTIONS (peak {args.gpu_peak_tflops:g} TFLOP/s, "
          f"utilisation {args.gpu_util}, DDP efficiency {args.ddp_eff}, link {args.link_gbps} GB/s)\n")
    for r, g in zip(kitti, gpu):
        print(f"  {r['recipe']}: train {r['train_frames']:,} + infer {r['infer_frames']:,} frames, "
              f"{r['flops'] / 1e15:,.1f} PFLOP; this CPU " + "; ".join(
                  f"{n} rate {c:,.0f} core-h ({c / 2 / 24:,.1f} days on 2 cores, ideal)"
                  for n, c in r["cpu_core_hours"].items()))
        print(f"    ASSUMED: 1 GPU {g['one_gpu_h'][0] * 60:.1f}-{g['one_gpu_h'][1] * 60:.1f} min; 8 GPUs "
              f"{g['eight_gpu_h'][0] * 60:.1f}-{g['eight_gpu_h'][1] * 60:.1f} min; step (batch {g['batch']}/GPU) "
              f"{g['step_s'][0] * 1e3:.1f}-{g['step_s'][1] * 1e3:.1f} ms; all-reduce {g['grad_mbytes']:.1f} MB "
              f"-> {g['allreduce_ms'][0]:.2f}-{g['allreduce_ms'][1]:.2f} ms; 8 GPUs eat "
              f"{g['frames_per_s_8gpu'][0]:,.0f}-{g['frames_per_s_8gpu'][1]:,.0f} frames/s = loader cores "
              + "; ".join(f"{n} {c[0]:.1f}-{c[1]:.1f}" for n, c in g["loader_cores_8gpu"].items()))



def _run_sweeps(args: argparse.Namespace, argv: list[str] | None) -> tuple[dict, dict]:
    """Measure the width, resolution and depth sweeps; return (run info, sweeps)."""
    torch.set_num_threads(args.threads)
    cmd = [os.path.relpath(sys.argv[0])] + (list(argv) if argv is not None else sys.argv[1:])
    info = {"command": "python " + " ".join(cmd),
                "start_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S"),
                "uptime_start": _uptime(), "torch": torch.__version__, "python": platform.python_version(),
                "machine": platform.machine(), "cpu_count": os.cpu_count(), "threads": args.threads,
                "batch": args.batch, "repeats": args.repeats}
    print(f"# {info['command']}\n# start {info['start_utc']} UTC; {info['uptime_start']}")
    if args.quick:
        crop, depth, base_w, widths, depths = (64, 208), 3, 16, (8, 16, 32), (2, 3, 4)
        crops = ((32, 104), (64, 208), (128, 416))
    else:
        crop, depth, base_w, widths, depths = (128, 416), 4, 32, (8, 16, 32, 64), (2, 3, 4, 5)
        crops = ((64, 208), (128, 416), (176, 608), (352, 1216))
    cache: dict[tuple, dict] = {}

    def point(width: int, d: int, hw: tuple[int, int]) -> dict:
        key = (width, d, hw)
        if key not in cache:
            train = hw[0] * hw[1] / 1e6 <= args.max_train_mp
            r = cache[key] = measure(width, d, *hw, args.batch, args.repeats, train=train)
            print(f"  w={width} d={d} {hw[0]}x{hw[1]}: infer {r['infer_cpu_s']:.3f} s/frame, "
                  f"train {r.get('train_cpu_s_step', float('nan')):.3f} s/step", flush=True)
        return cache[key]

    sweeps = {
        "width": [point(w, depth, crop) for w in widths],
        "resolution": [point(base_w, depth, hw) for hw in crops],
        "depth": [point(base_w, d, crop) for d in depths],
    }
    info["end_utc"] = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    info["uptime_end"] = _uptime()
    print(f"# end {info['end_utc']} UTC; {info['uptime_end']}")
    return info, sweeps


def _fits(sweeps: dict[str, list[dict]], all_rows: list[dict]) -> dict[str, dict[str, float]]:
    """All fits of CPU time: per GFLOP (through the origin and affine), vs pixels, power laws."""
    trained = [r for r in all_rows if "train_cpu_s_step" in r]
    step_gflop = [r["train_gflop_frame"] * r["batch"] for r in trained]
    step_s = [r["train_cpu_s_step"] for r in trained]
    inf_gflop, inf_s = [r["fwd_gflop_frame"] for r in all_rows], [r["infer_cpu_s"] for r in all_rows]
    fits = {
        "train_s_per_gflop": fit_line(step_gflop, step_s, through_origin=True),
        "train_vs_gflop": fit_line(step_gflop, step_s),
        "train_power_gflop": fit_power(step_gflop, step_s),
        "infer_s_per_gflop": fit_line(inf_gflop, inf_s, through_origin=True),
        "infer_vs_gflop": fit_line(inf_gflop, inf_s),
        "infer_power_gflop": fit_power(inf_gflop, inf_s),
    }
    res = sweeps["resolution"]
    fits["infer_vs_mp"] = fit_line([r["megapixels"] for r in res], [r["infer_cpu_s"] for r in res])
    res_tr = [r for r in res if "train_cpu_s_step" in r]
    if len(res_tr) >= 2:
        fits["train_vs_mp"] = fit_line([r["megapixels"] for r in res_tr], [r["train_cpu_s_frame"] for r in res_tr])
    wid = sweeps["width"]
    if all("train_cpu_s_step" in r for r in wid):
        fits["train_power_width"] = fit_power([r["width"] for r in wid], [r["train_cpu_s_step"] for r in wid])
    fits["infer_power_width"] = fit_power([r["width"] for r in wid], [r["infer_cpu_s"] for r in wid])
    fits["flops_power_width"] = fit_power([r["width"] for r in wid], [r["fwd_gflop_frame"] for r in wid])
    fits["params_power_width"] = fit_power([r["width"] for r in wid], [r["params"] for r in wid])
    dep = [r for r in sweeps["depth"] if "train_cpu_s_step" in r]
    if len(dep) >= 2:
        fits["train_vs_depth_gflop"] = fit_line([r["train_gflop_frame"] * r["batch"] for r in dep],
                                                [r["train_cpu_s_step"] for r in dep], through_origin=True)
    return fits


if __name__ == "__main__":
    main()
