"""The prepared GPU check: CUDA tests, training and predict throughput, one run.

On the device machine (one NVIDIA H200), one call of the device tool, ``timeout_s=480``,
``carry=[".whl"]``::

    set -o pipefail; python3 -m pip install -q --no-index --no-deps --no-compile \\
      --no-cache-dir --upgrade --target /tmp/site .whl/*.whl && \\
      export PYTHONPATH=/tmp/site:$PWD || exit; PYTHONUNBUFFERED=1 python3 \\
      perf/gpu_check.py --out $OUT/gpu_check.json 2>&1 | tee $OUT/gpu_check.log

The check stops itself at ``--max-seconds`` (default 420 s: a fresh machine's start takes
a minute or more of the 15-minute lease, so the 480 s limit leaves room for one short
rerun). Its image has torch, numpy, OpenCV, scikit-learn, safetensors, matplotlib, tqdm,
joblib and pytest with pytest-timeout, but not gymnasium (imported by ``inpaintenv``) nor
its need Farama-Notifications. Carry them as wheels, prepared here once, in the repository
root (``.whl/`` is ignored by git and travels only when named in ``carry``; 0.5 MB)::

    echo /.whl/ >> .git/info/exclude
    python3 -m pip download --no-deps --only-binary=:all: --python-version 3.12 \\
      --implementation cp --platform manylinux_2_17_x86_64 -d .whl \\
      gymnasium==1.4.0 farama-notifications==0.0.6

The repository is not installed there: ``PYTHONPATH=$PWD`` makes ``inpaintenv`` and
``estimators`` importable (the test subprocesses inherit it).

Sections, each printed as it ends, then one JSON summary line (``JSON {...}``), also
written to ``--out`` (default ``$OUT/gpu_check.json`` when ``$OUT`` is set):

1. ``pytest -m gpu tests/gpu``: bf16 autocast, a 1-process DDP job (nccl on CUDA, gloo on
   the CPU), checkpoint resume on the device, same-seed fits, the same training samples on
   the CPU and the device; the counts of passed, failed, errors and skipped tests.
2. Training throughput of preset ``study-unet-tv``'s network and loss (its U-Net, L1 +
   λ hole L1 + β TV, Adam) on whole 352×1216 frames at batch 4, 16 and 64, fp32 and bf16
   autocast: samples/s, model FLOP/s (``FlopCounterMode`` over one step's forward and
   backward on the meta device: the convolutions; per timed step) and its share of the GPU's dense bf16 peak (a table
   of datasheet peaks by device name; otherwise "peak unknown"), the share of the step time
   spent blocked in the loader's ``next()`` (each step ends with a CUDA synchronisation),
   and peak GPU memory (``torch.cuda.max_memory_allocated``). The step is that of
   ``UNetInpainter.fit`` (input encoding, loss, autocast), written out here as in
   ``scaling_training.py``; the samples come from fit's data path (``OcclusionFrames``
   through ``TrainingBatches``: one loader with ``--workers`` persistent workers and pinned
   memory on CUDA) over in-memory synthetic frames, so PNG decoding is not part of it.
   ``--sample-device train`` makes every row's samples as ``sample_device="train"`` does
   (the workers hand over whole frames; crop and ``rect-v1`` occlusions are made on the
   device). One more row runs batch 16 bf16 with the estimator's default ``num_workers=0``
   (samples loaded in the training process).
3. ``predict`` throughput, frames/s, on the CPU and on CUDA: the default release
   (``pretrained`` from the registry, kitti-ensemble-v1) and a ``study-unet-tv`` U-Net
   (weights after one training step: the time does not depend on them). A model without a
   ``device`` parameter (the release's blend ensemble) predicts on the CPU only; its CUDA
   row says so instead of a figure.
4. The environment (device name, torch, CUDA, cuDNN) and the JSON summary.

``--quick`` runs the same sections and prints the same lines and keys on the CPU in under a
minute on two cores (32×96 frames, batch 2, 2 timed steps, 2 frames to predict; the tests
of section 1 with ``INPAINTENV_GPU_TESTS_ON_CPU=1``): CI runs it
(tests/perf/test_gpu_check.py).

Examples
--------
    python perf/gpu_check.py --quick
    python perf/gpu_check.py --out gpu_check.json --max-seconds 420
    python perf/gpu_check.py --skip-tests --sample-device train --out gpu_check_train.json
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from _gpu_check_machine import NEEDS, Budget, bf16_peak_tflops, environment, run_gpu_tests
from torch.utils.flop_counter import FlopCounterMode

from estimators.learned._sampling import TrainingBatches
from estimators.learned._training_data import OcclusionFrames, encode_input
from estimators.learned.losses import inpainting_loss
from estimators.learned.nets import UNet
from estimators.learned.presets import make_preset
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.base import DepthDataset
from inpaintenv.files import write_json
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method

PRESET = "study-unet-tv"


# -- 2. training throughput --------------------------------------------------------------
class CycledFrames(DepthDataset):
    """``length`` frames cycling through a small in-memory pool (decoded once, as a cache would)."""

    def __init__(self, pool: np.ndarray, length: int):
        self.pool = pool
        self.frame_shape = tuple(pool.shape[1:])
        self.groups = np.array([f"synthetic{i % len(pool)}" for i in range(length)])
        self.frame_ids = [f"{g}/{i}" for i, g in enumerate(self.groups)]

    def _load(self, index: int) -> np.ndarray:
        return self.pool[index % len(self.pool)]


def preset_config() -> dict[str, Any]:
    """The network and loss parameters of preset ``study-unet-tv``."""
    params = make_preset(PRESET).get_params()
    keys = ("width", "depth", "input_mask", "depth_scale", "hole_weight", "tv_weight", "max_depth", "lr",
            "weight_decay", "protocol")
    if params["depth_scale"] != "fixed":
        raise ValueError(f"preset {PRESET!r} has depth_scale={params['depth_scale']!r}; this check writes out 'fixed'")
    return {k: params[k] for k in keys}


def make_step(cfg: dict[str, Any], model: torch.nn.Module, device: torch.device, bf16: bool,
              channels_last: bool) -> Any:
    """One optimiser step as ``UNetInpainter.fit`` takes it (depth_scale "fixed")."""
    optimizer = torch.optim.Adam(model.parameters(), lr=cfg["lr"], weight_decay=cfg["weight_decay"])
    autocast = torch.autocast(device.type, dtype=torch.bfloat16) if bf16 else contextlib.nullcontext()

    def step(gt: torch.Tensor, hole: torch.Tensor) -> torch.Tensor:
        gt = gt.to(device, non_blocking=True)
        hole = hole.to(device, non_blocking=True)
        target = gt / cfg["max_depth"]
        x = encode_input(torch.where(hole, torch.zeros_like(gt), gt), hole, cfg["max_depth"], cfg["input_mask"])
        if channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        optimizer.zero_grad(set_to_none=True)
        with autocast:
            pred = model(x)[:, 0]
        loss = inpainting_loss(pred.float(), target, gt > 0, hole, cfg["hole_weight"], cfg["tv_weight"])
        loss.backward()
        optimizer.step()
        return loss.detach()

    return step


def train_step_flops(cfg: dict[str, Any], batch: int, frame: tuple[int, int]) -> int:
    """FLOPs of one training step's forward and backward, counted by ``FlopCounterMode``.

    Counted on the meta device (the same operators and shapes, no arithmetic, a fraction of
    a second): the convolutions forward and backward, 2 FLOPs per multiply-add; the loss,
    the normalisations and Adam have no matrix products and are not counted. The input
    needs no gradient, as in training.
    """
    with torch.device("meta"):
        model = UNet(3 if cfg["input_mask"] else 1, cfg["width"], cfg["depth"], skip=True)
        x = torch.empty(batch, model.in_channels, *frame)
    with FlopCounterMode(display=False) as counter:
        model(x)[:, 0].sum().backward()
    return int(counter.get_total_flops())


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def measure_training(cfg: dict[str, Any], pool: np.ndarray, batch: int, bf16: bool, device: torch.device, *,
                     warmup: int, max_steps: int, seconds: float, workers: int, peak: float | None,
                     channels_last: bool = False, sample_device: str = "cpu") -> dict[str, Any]:
    """Samples/s, model FLOP/s, data-wait share and peak memory of one batch size and precision
    (``sample_device``: "cpu", samples made in the loader; "train", on ``device``)."""
    row: dict[str, Any] = {"batch": batch, "precision": "bf16" if bf16 else "fp32",
                           "frame": list(pool.shape[1:]), "workers": workers, "sample_device": sample_device}
    if device.type == "cuda":
        torch.cuda.empty_cache()
        torch.cuda.reset_peak_memory_stats(device)
    torch.manual_seed(0)
    model = UNet(3 if cfg["input_mask"] else 1, cfg["width"], cfg["depth"], skip=True).to(device)
    if channels_last:
        model = model.to(memory_format=torch.channels_last)
    model.train()
    step = make_step(cfg, model, device, bf16, channels_last)
    n = batch * (warmup + max_steps)
    data = OcclusionFrames(CycledFrames(pool, n), get_protocol(cfg["protocol"]), None, seed=0)
    row["flop_per_step"] = train_step_flops(cfg, batch, tuple(pool.shape[1:]))
    loader = TrainingBatches(data, batch, workers, device, on_device=sample_device == "train")
    batches = loader.epoch(0, np.arange(n))
    for _ in range(warmup):
        step(*next(batches))
    _sync(device)
    wait = total = 0.0
    losses = []
    t_end = time.perf_counter() + seconds
    for k in range(max_steps):
        t0 = time.perf_counter()
        gt, hole = next(batches)
        t1 = time.perf_counter()
        losses.append(step(gt, hole))
        _sync(device)
        t2 = time.perf_counter()
        wait, total = wait + t1 - t0, total + t2 - t0
        if k >= 1 and t2 > t_end:
            break
    del batches
    loader.close()  # stops the loader's workers
    steps = len(losses)
    row.update(steps=steps, step_ms=1e3 * total / steps, samples_per_s=batch * steps / total,
               data_wait_share=wait / total, model_tflops=row["flop_per_step"] * steps / total / 1e12,
               final_loss=float(losses[-1]))
    row["bf16_peak_share"] = row["model_tflops"] / peak if peak else None
    row["peak_gpu_memory_bytes"] = torch.cuda.max_memory_allocated(device) if device.type == "cuda" else None
    if not all(math.isfinite(float(v)) for v in losses):
        row["error"] = "non-finite training loss"
    return row


def training_line(row: dict[str, Any], peak: float | None) -> str:
    """One printed line per training row."""
    made = " sampled on the device" if row.get("sample_device") == "train" else ""
    head = f"train batch={row['batch']} {row['precision']} workers={row['workers']}{made}:"
    if "samples_per_s" not in row:
        return f"{head} not measured ({row.get('skipped') or row.get('error')})"
    share = f"{100 * row['bf16_peak_share']:.1f} % of the bf16 dense peak {peak:g}" if peak else "peak unknown"
    mem = row["peak_gpu_memory_bytes"]
    mem_s = f"{mem / 2**30:.2f} GiB" if mem is not None else "n/a (cpu)"
    return (f"{head} {row['samples_per_s']:.2f} samples/s, step {row['step_ms']:.1f} ms ({row['steps']} steps), "
            f"data wait {100 * row['data_wait_share']:.1f} % of step time, model {row['model_tflops']:.3f} TFLOP/s "
            f"({row['flop_per_step'] / 1e9:.1f} GFLOP/step; {share}), peak GPU memory {mem_s}"
            + (f"; ERROR {row['error']}" if row.get("error") else ""))


def training_rows(batches: list[int], workers: int) -> list[tuple[int, bool, int]]:
    """(batch, bf16, loader workers) of each row: every batch in fp32 and bf16 with ``workers``,
    then the middle batch in bf16 with the estimator's default ``num_workers=0``."""
    rows = [(batch, bf16, workers) for batch in batches for bf16 in (False, True)]
    if workers:
        rows.append((16 if 16 in batches else batches[len(batches) // 2], True, 0))
    return rows


def run_training(args: argparse.Namespace, device: torch.device, peak: float | None, budget: Budget) -> list[dict]:
    cfg = preset_config()
    pool = SyntheticStreets(n=args.pool, seed=0, frame_shape=tuple(args.frame)).load_batch(range(args.pool))
    rows = []
    for batch, bf16, workers in training_rows(args.batches, args.workers):
        what = {"batch": batch, "precision": "bf16" if bf16 else "fp32", "workers": workers,
                "sample_device": args.sample_device}
        if not budget.allows(f"training batch={batch} {what['precision']} workers={workers}",
                             NEEDS["train"] if not args.quick else 1.0):
            rows.append({**what, "skipped": "--max-seconds"})
        else:
            try:
                rows.append(measure_training(cfg, pool, batch, bf16, device, warmup=args.warmup,
                                             max_steps=args.steps, seconds=args.train_seconds, workers=workers,
                                             peak=peak, channels_last=args.channels_last,
                                             sample_device=args.sample_device))
            except (torch.cuda.OutOfMemoryError, RuntimeError) as exc:  # one batch size failing is a finding
                rows.append({**what, "error": f"{type(exc).__name__}: {str(exc).splitlines()[0][:300]}"})
                if device.type == "cuda":
                    torch.cuda.empty_cache()
        print(training_line(rows[-1], peak), flush=True)
    return rows


# -- 3. predict throughput ---------------------------------------------------------------
def predict_models(frame: tuple[int, int]) -> dict[str, tuple[Any, str]]:
    """name -> (fitted estimator, what its weights are)."""
    small = SyntheticStreets(n=2, seed=1, frame_shape=(64, 192))
    unet = make_preset(PRESET, max_steps=1, crop=(64, 192), device="cpu", random_state=0).fit(small)
    return {"pretrained": (make_method("pretrained"), "the default release (kitti-ensemble-v1)"),
            PRESET: (unet, "its U-Net after 1 training step (time does not depend on the weights)")}


def measure_predict(est: Any, x: np.ndarray, device: str, seconds: float) -> dict[str, Any]:
    """Frames/s of ``est.predict`` on ``x`` after one warm-up call, repeated for ``seconds``."""
    if "device" in est.get_params():
        est.set_params(device=device)
    elif device != "cpu":
        return {"device": device, "skipped": f"{type(est).__name__} has no device parameter: it predicts on the CPU"}
    est.predict(x[:1])  # warm-up: the move to the device, cuDNN's first choice of kernels
    frames, t0 = 0, time.perf_counter()
    while True:
        out = est.predict(x)
        frames += len(x)
        if time.perf_counter() - t0 > seconds:
            break
    wall = time.perf_counter() - t0
    return {"device": device, "frames": frames, "seconds": wall, "frames_per_s": frames / wall,
            "finite": bool(np.isfinite(out).all())}


def run_predict(args: argparse.Namespace, cuda: bool, budget: Budget) -> list[dict]:
    shape = tuple(args.frame)
    gt = SyntheticStreets(n=args.predict_frames, seed=2, frame_shape=shape).load_batch(range(args.predict_frames))
    hole = get_protocol("rect-v1").masks(shape, 0, range(args.predict_frames))
    x = np.where(hole, np.nan, gt).astype(np.float32)
    rows = []
    for name, (est, weights) in predict_models(shape).items():
        for device in ("cpu", "cuda"):
            row: dict[str, Any] = {"model": name, "weights": weights, "device": device, "frame": list(shape)}
            if device == "cuda" and not cuda:
                row["skipped"] = "no CUDA device"
            elif budget.allows(f"predict {name} {device}", NEEDS["predict"] if not args.quick else 1.0):
                row.update(measure_predict(est, x, device, args.predict_seconds))
            else:
                row["skipped"] = "--max-seconds"
            rows.append(row)
            what = (f"{row['frames_per_s']:.2f} frames/s ({row['frames']} frames {shape[0]}x{shape[1]})"
                    if "frames_per_s" in row else f"not measured ({row['skipped']})")
            print(f"predict {name} {device}: {what}", flush=True)
    return rows


# -- main ----------------------------------------------------------------------------------
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="CPU, tiny frames, in under a minute (CI)")
    p.add_argument("--out", default=None, help="write the JSON summary here (default $OUT/gpu_check.json if $OUT is set)")
    p.add_argument("--max-seconds", type=float, default=None,
                   help="skip what would end past this many seconds (default 420; quick 90)")
    p.add_argument("--batches", type=int, nargs="+", default=None, help="training batches (default 4 16 64; quick 2)")
    p.add_argument("--steps", type=int, default=None, help="most timed training steps per row (default 200; quick 2)")
    p.add_argument("--warmup", type=int, default=None, help="untimed steps first (default 2; quick 1)")
    p.add_argument("--threads", type=int, default=None, help="torch.set_num_threads (default torch's; quick 1)")
    p.add_argument("--train-seconds", type=float, default=None, help="timed seconds per training row (default 12)")
    p.add_argument("--workers", type=int, default=None, help="loader workers (default min(8, cores - 2); quick 1)")
    p.add_argument("--pool", type=int, default=None, help="distinct synthetic frames in memory (default 16; quick 4)")
    p.add_argument("--predict-frames", type=int, default=None, help="frames per predict call (default 8; quick 2)")
    p.add_argument("--predict-seconds", type=float, default=None, help="seconds per predict row (default 8)")
    p.add_argument("--channels-last", action="store_true", help="train in the channels-last memory format")
    p.add_argument("--cudnn-benchmark", action="store_true", help="torch.backends.cudnn.benchmark = True")
    p.add_argument("--sample-device", choices=("cpu", "train"), default="cpu",
                   help="where training samples are cropped and occluded: in the loader (cpu, default) or on "
                        "the training device (train), as the estimators' sample_device")
    p.add_argument("--skip-tests", action="store_true", help="leave out section 1")
    args = p.parse_args(argv)
    quick = args.quick
    defaults = {"max_seconds": 90.0 if quick else 420.0, "warmup": 1 if quick else 2, "threads": 1 if quick else 0, "batches": [2] if quick else [4, 16, 64],
                "steps": 2 if quick else 200, "train_seconds": 0.0 if quick else 12.0,
                "workers": 1 if quick else max(1, min(8, (os.cpu_count() or 2) - 2)), "pool": 4 if quick else 16,
                "predict_frames": 2 if quick else 8, "predict_seconds": 0.0 if quick else 8.0}
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    args.frame = (32, 96) if quick else (352, 1216)
    for key in ("steps", "pool", "predict_frames"):
        if getattr(args, key) < 1:
            p.error(f"--{key.replace('_', '-')} must be >= 1, got {getattr(args, key)}")
    if min(args.batches) < 1 or args.workers < 0 or args.warmup < 1 or args.max_seconds <= 0 or args.threads < 0:
        p.error("--batches and --warmup must be >= 1, --workers and --threads >= 0, --max-seconds > 0")
    return args


def main(argv: list[str] | None = None) -> dict[str, Any]:
    args = parse_args(argv)
    budget = Budget(args.max_seconds)
    cuda = torch.cuda.is_available() and not args.quick
    device = torch.device("cuda" if cuda else "cpu")
    torch.backends.cudnn.benchmark = args.cudnn_benchmark
    if args.threads:
        torch.set_num_threads(args.threads)
    env = environment(device)
    peak = bf16_peak_tflops(env["device_name"]) if cuda else None
    print(f"# gpu_check {'--quick ' if args.quick else ''}(--max-seconds {args.max_seconds:g})")
    print(f"device: {env['device_name']}; torch {env['torch']}; CUDA {env['cuda']}; cuDNN {env['cudnn']}; "
          f"{env['cpu_count']} CPU cores, {env['torch_threads']} torch threads; commit {env['git_commit']}")
    shm = env["shm_free_bytes"]
    print(f"cuDNN TF32 allowed: {env['cudnn_allow_tf32']}; cuDNN benchmark: {env['cudnn_benchmark']}; "
          f"/dev/shm free: {f'{shm / 2**30:.1f} GiB' if shm is not None else 'none'}")
    print(f"bf16 dense peak: {f'{peak:g} TFLOP/s (datasheet)' if peak else 'peak unknown'}", flush=True)
    sections: dict[str, str] = {}

    print("\n## 1. tests marked gpu", flush=True)
    tests: dict[str, Any] = {}
    if args.skip_tests:
        sections["tests"] = "skipped: --skip-tests"
    elif budget.allows("tests marked gpu", NEEDS["tests"] if not args.quick else 1.0):
        tests = run_gpu_tests(force_cpu=not cuda, timeout=max(1.0, min(180.0, budget.left())))
        sections["tests"] = "ran"
    else:
        sections["tests"] = "skipped: --max-seconds"
    if tests:
        print(f"tests: {tests['passed']} passed, {tests['failed']} failed, {tests['errors']} errors, "
              f"{tests['skipped']} skipped on {'cuda' if cuda else 'cpu (forced)'} in {tests['seconds']:.1f} s"
              + (f"; {tests['error']}" if tests["error"] else ""))
        for name in tests["failures"]:
            print(f"  FAILED {name}")
        if tests.get("output_tail"):
            print(tests["output_tail"])
    else:
        print(f"tests: not run ({sections['tests']})")

    print(f"\n## 2. training throughput: {PRESET} network and loss, {args.frame[0]}x{args.frame[1]} frames, "
          f"{args.workers} loader workers" + (", samples made on the device" if args.sample_device == "train" else ""),
          flush=True)
    training = run_training(args, device, peak, budget)
    sections["training"] = "ran" if any("samples_per_s" in r for r in training) else "skipped"

    print(f"\n## 3. predict throughput: {args.frame[0]}x{args.frame[1]} frames", flush=True)
    predict = run_predict(args, cuda, budget) if budget.allows("predict", 1.0) else []
    sections["predict"] = "ran" if any("frames_per_s" in r for r in predict) else "skipped"

    summary = {"mode": "quick" if args.quick else "full", "environment": env, "bf16_peak_tflops": peak,
               "sections": sections, "tests": tests, "training": training, "predict": predict,
               "elapsed_s": budget.elapsed(), "max_seconds": args.max_seconds}
    print("\n## 4. summary", flush=True)
    out = args.out or (str(Path(os.environ["OUT"]) / "gpu_check.json") if os.environ.get("OUT") else None)
    if out:
        write_json(out, summary)
        print(f"wrote {out}")
    print(f"elapsed {budget.elapsed():.1f} s")
    print("JSON " + json.dumps(summary), flush=True)
    return summary


if __name__ == "__main__":
    main()
