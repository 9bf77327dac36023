"""Train the study's GPU recipes on every leave-one-day-out fold, for CPU scoring after.

For each fold of ``experiments/lodo_days.sh`` -- each recording day of KITTI's train split
left out, then drive ``2011_09_26_drive_0001_sync`` (the official maps) left out -- train
preset ``study-autoencoder-gpu`` on the other drives (both cameras), then
``study-unet-tv-gpu`` warm-started from it (the study's two stages), each stage inside its
share of ``--minutes`` (``max_minutes``; the whole run stops at ``--minutes`` after its
start). Drives come from the data layer (``KittiDepth(...).groups``, opened with
``drives=``): a fold's training drives and its left-out drives never share a drive.

Writes, under ``--out`` (default ``$OUT``):

- ``<fold>/unet-tv/`` the fold's U-Net (``config.json`` + ``model.safetensors``, 7.9 MB;
  the autoencoder stage is not kept: its encoder lives on in the U-Net);
- ``<fold>/fold.json`` its drives on each side, steps, minutes and whether the budget
  stopped each stage, the device and torch version;
- ``score_folds.sh`` the CPU commands, printed too, that score each fold's U-Net on its
  left-out frames against the classical suite (``inpaintenv benchmark --checkpoint ...``,
  the frames and seeds of ``lodo_days.sh``), with ``--score-root`` (default
  ``--kitti-root``) as the KITTI root they read.

The device machine (one NVIDIA H200, 15 minutes of device time a session, 10 a call) copies
the repository's tracked and untracked-not-ignored files plus the ``carry`` paths, 64 MiB in
all, and brings back at most 8 files of 16 MiB (64 MiB together, two folders down at most).
``/work/shared/kitti`` is 150 MB (123 MB of ground truth): it does not fit. Training needs
only the ground truth (occlusions are drawn on it) and never the left-out drives, so carry
the ground truth of 13 of the 15 train drives, 48 MB, in a folder ``.gitignore`` does not
list but ``.git/info/exclude`` does, prepared here once in the repository root::

    echo /.kitti-gpu/ >> .git/info/exclude
    for d in /work/shared/kitti/train/*_sync; do case $d in *0001_sync|*9004_sync) continue;; esac
      mkdir -p .kitti-gpu/train/${d##*/}/proj_depth
      cp -r $d/proj_depth/groundtruth .kitti-gpu/train/${d##*/}/proj_depth/; done
    du -sh .kitti-gpu   # 48M: with the ~7 MB repository and .whl (0.5 MB), under 64 MiB

Left behind: drive 0001 (35 MB, the official maps; left out of its own fold anyway) and
9004 (41 MB): every GPU fold trains on its ``lodo_days.sh`` drives less these two, and the
rows must say so. The wheels ``.whl/`` are those of ``perf/gpu_check.py`` (gymnasium,
Farama-Notifications). Then one call of the device tool, ``timeout_s=560``,
``carry=[".whl", ".kitti-gpu"]``::

    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \\
      --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site:$PWD || exit;
    PYTHONUNBUFFERED=1 python3 perf/gpu_train_folds.py --kitti-root .kitti-gpu \\
      --score-root /work/shared/kitti --out $OUT/folds --minutes 8 2>&1 | tee $OUT/train.log;
    cd $OUT && tar -cf - folds | split -b 15m - folds.tar. && rm -rf folds

(8 minutes for 4 folds: 1 minute a stage, so the 560 s limit leaves room for the PNG decoding
and the start; 4 U-Nets of 7.9 MB come back as 3 tar parts and the log). Here, unpack with
``cat folds.tar.* | tar -xf -``, then write the scoring commands from the whole data (the
slice lacks drives 0001 and 9004, which the folds of day 2011_09_26 and drive 0001 score;
``--score-only`` refuses a left-out drive a fold trained on) and run them on the CPU::

    python perf/gpu_train_folds.py --score-only --kitti-root /work/shared/kitti --out folds
    bash folds/score_folds.sh To give a
fold the recipes' own 4 minutes a stage, train it alone: ``--folds day-2011_09_26
--minutes 8``.

``--quick`` runs the same on the CPU in seconds: without ``--kitti-root``, on a tiny synthetic
tree in KITTI's layout written to ``<out>/synthetic-kitti`` (three days and drive 0001, two frames a drive), with 2-step stages of
a 4-channel network on 32×64 crops (tests/perf/test_gpu_train_folds.py).

Examples
--------
    python perf/gpu_train_folds.py --quick --out /tmp/folds
    python perf/gpu_train_folds.py --kitti-root .kitti-gpu --out runs/gpu-folds --minutes 8
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

OFFICIAL = "2011_09_26_drive_0001_sync"
STAGES = ("study-autoencoder-gpu", "study-unet-tv-gpu")
#: ``--quick``: a 4-channel network on 32×64 crops, 2 steps a stage, in this process;
#: max_depth 20 keeps the untrained network's fill under the 256 m a KITTI PNG holds, so
#: the printed benchmark commands score it (at 80 m its outputs of ~3.3 reach 262 m).
QUICK = dict(width=4, depth=2, crop=(32, 64), batch_size=2, max_steps=2, num_workers=0, device="cpu",
             num_threads=1, max_depth=20.0)


class Fold(NamedTuple):
    """One fold: its name (as ``lodo_days.sh`` names it), the drives it trains on and leaves out."""

    name: str
    train: tuple[str, ...]
    held: tuple[str, ...]
    camera: str  # the camera its left-out frames are scored on


def make_folds(drives: list[str]) -> list[Fold]:
    """The leave-one-day-out folds of ``drives`` (the train split's), then drive 0001 left out.

    Raises
    ------
    ValueError
        If a fold would train on a drive it leaves out, or has nothing to train on.
    """
    drives = sorted(set(drives))
    folds = [Fold(f"day-{day}", tuple(d for d in drives if not d.startswith(day)),
                  tuple(d for d in drives if d.startswith(day)), "image_02")
             for day in sorted({d[:10] for d in drives})]
    folds.append(Fold("drive-0001", tuple(d for d in drives if d != OFFICIAL), (OFFICIAL,), "both"))
    for fold in folds:
        if set(fold.train) & set(fold.held):
            raise ValueError(f"fold {fold.name}: drives on both sides: {sorted(set(fold.train) & set(fold.held))}")
        if not fold.train:
            raise ValueError(f"fold {fold.name}: no drive left to train on (drives: {drives})")
    return folds


def write_synthetic_kitti(root: Path, shape: tuple[int, int] = (352, 1216)) -> Path:
    """A tiny tree in KITTI's depth-completion layout: one drive a day and drive 0001, two frames each."""
    from inpaintenv.data.io import write_depth_png

    rng = np.random.default_rng(0)
    rows = np.linspace(5.0, 60.0, shape[0])[:, None] + np.linspace(0.0, 4.0, shape[1])[None, :]
    drives = {"2011_09_26_drive_9001_sync": ("image_02",), "2011_09_30_drive_9018_sync": ("image_02",),
              "2011_10_03_drive_9027_sync": ("image_02",), OFFICIAL: ("image_02", "image_03")}
    for k, (drive, cameras) in enumerate(drives.items()):
        for camera in cameras:
            folder = root / "train" / drive / "proj_depth" / "groundtruth" / camera
            folder.mkdir(parents=True, exist_ok=True)
            for frame in range(2):
                depth = (rows + k + frame) * (rng.random(shape) < 0.3)
                write_depth_png(folder / f"{frame + 5:010d}.png", depth)
    return root


def _stage_record(est: Any, seconds: float) -> dict[str, Any]:
    history = getattr(est, "history_", {}) or {}
    return {"steps": int(est.n_steps_), "seconds": round(seconds, 2), "budget_stop": history.get("budget_stop"),
            "final_loss": history["step_loss"][-1] if history.get("step_loss") else None}


def train_fold(fold: Fold, root: Path, out: Path, stage_minutes: float, deadline: float,
               overrides: dict[str, Any]) -> dict[str, Any]:
    """Train the fold's two stages (each within ``stage_minutes`` and before ``deadline``) and save its U-Net."""
    import torch

    from estimators.learned.presets import make_preset
    from inpaintenv.data import KittiDepth

    data = KittiDepth(root, split="train", camera="both", drives=list(fold.train))
    record: dict[str, Any] = {"fold": fold.name, "train_drives": list(fold.train), "held_drives": list(fold.held),
                              "frames": len(data), "torch": torch.__version__, "stages": {}}
    previous = None
    for preset in STAGES:
        minutes = max(min(stage_minutes, (deadline - time.monotonic()) / 60.0), 1e-3)
        extra = {} if previous is None else {"warm_start": previous}
        est = make_preset(preset, max_minutes=minutes, **extra, **overrides)
        start = time.perf_counter()
        est.fit(data)
        record["stages"][preset] = {**_stage_record(est, time.perf_counter() - start), "max_minutes": minutes}
        record["device"] = str(est._device())
        previous = est
    record["device_name"] = torch.cuda.get_device_name() if record["device"].startswith("cuda") else "cpu"
    previous.save(out / fold.name / "unet-tv")
    from inpaintenv.files import write_json
    write_json(out / fold.name / "fold.json", record)
    return record


def score_commands(folds: list[Fold], out: Path, score_root: str) -> list[str]:
    """The CPU ``inpaintenv benchmark`` command of each fold, on its left-out frames (as lodo_days.sh)."""
    lines = []
    for fold in folds:
        argv = ["inpaintenv", "benchmark", "--kitti-root", score_root, "--split", "train", "--camera", fold.camera,
                "--drives", *fold.held, "--holdout", "0", "--suite", "classical",
                "--checkpoint", f"study-unet-tv-gpu-without-{fold.name}={out / fold.name / 'unet-tv'}",
                "--seed", "0", "--seed", "1", "--figure-frames", "0", "--out", str(out / f"bench-{fold.name}")]
        lines.append(" ".join(shlex.quote(a) for a in argv))
    return lines


def scored_folds(root: Path, out: Path) -> list[Fold]:
    """The folds of ``root`` (the whole data, here) that ``out`` holds a trained fold of, their left-out
    drives those of ``root``; a drive the fold trained on (its ``fold.json``) may not be scored.

    Raises
    ------
    ValueError
        If a left-out drive of ``root`` is one the fold trained on, or ``out`` holds no fold.
    """
    from inpaintenv.data import KittiDepth
    from inpaintenv.files import read_json

    folds = []
    for fold in make_folds([str(g) for g in KittiDepth(root, split="train", camera="both").groups]):
        path = out / fold.name / "fold.json"
        if not path.is_file():
            continue
        trained = set(read_json(path, "fold record")["train_drives"])
        if trained & set(fold.held):
            raise ValueError(f"{path}: fold {fold.name} trained on {sorted(trained & set(fold.held))}, "
                             f"which {root} leaves out")
        folds.append(fold._replace(train=tuple(sorted(trained))))
    if not folds:
        raise ValueError(f"no trained fold (<fold>/fold.json) in {out}")
    return folds


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kitti-root", help="KITTI root to train on (default with --quick: a synthetic tree)")
    p.add_argument("--score-root", help="KITTI root the printed scoring commands read (default --kitti-root)")
    p.add_argument("--out", default=os.environ.get("OUT"), metavar="DIR", help="output folder (default $OUT)")
    p.add_argument("--minutes", type=float, default=8.0, help="training budget of the whole run (default 8)")
    p.add_argument("--folds", nargs="+", metavar="NAME", help="train only these folds (e.g. day-2011_09_26)")
    p.add_argument("--quick", action="store_true", help="tiny CPU run (seconds)")
    p.add_argument("--score-only", action="store_true",
                   help="train nothing: write and print the scoring commands of the folds in --out, their "
                        "left-out drives read from --kitti-root (the whole data, on the CPU)")
    args = p.parse_args(argv)
    if args.out is None:
        p.error("--out is required when $OUT is not set")
    if args.minutes <= 0:
        p.error(f"--minutes must be > 0, got {args.minutes}")
    if args.kitti_root is None and not args.quick:
        p.error("--kitti-root is required (or --quick)")
    start = time.monotonic()
    out = Path(args.out)
    if args.score_only:
        if args.kitti_root is None:
            p.error("--score-only needs --kitti-root (the data to score on)")
        _write_commands(scored_folds(Path(args.kitti_root), out), out, args.kitti_root)
        return 0
    out.mkdir(parents=True, exist_ok=True)
    # --quick without a root: the synthetic tree stays in --out, so the printed commands run.
    root = Path(args.kitti_root) if args.kitti_root else write_synthetic_kitti(out / "synthetic-kitti")
    from inpaintenv.data import KittiDepth

    folds = make_folds([str(g) for g in KittiDepth(root, split="train", camera="both").groups])
    if args.folds:
        unknown = sorted(set(args.folds) - {f.name for f in folds})
        if unknown:
            p.error(f"unknown fold(s) {unknown}; folds: {[f.name for f in folds]}")
        folds = [f for f in folds if f.name in args.folds]
    stage_minutes = args.minutes / (len(STAGES) * len(folds))
    overrides = QUICK if args.quick else {}
    deadline = start + 60.0 * args.minutes
    for fold in folds:
        rec = train_fold(fold, root, out, stage_minutes, deadline, overrides)
        steps = ", ".join(f"{k} {v['steps']} steps / {v['seconds']:.0f} s" for k, v in rec["stages"].items())
        print(f"{fold.name}: {rec['frames']} frames of {len(fold.train)} drives on {rec['device_name']}: {steps}",
              flush=True)
    _write_commands(folds, out, args.score_root or str(root))
    print(f"total {(time.monotonic() - start) / 60:.2f} min")
    return 0


def _write_commands(folds: list[Fold], out: Path, score_root: str) -> None:
    commands = score_commands(folds, out, score_root)
    from inpaintenv.files import write_text_atomic
    write_text_atomic(out / "score_folds.sh", "#!/usr/bin/env bash\nset -euo pipefail\n" + "\n".join(commands) + "\n")
    print(f"\nscore on the CPU ({out / 'score_folds.sh'}):")
    print("\n".join(commands))


if __name__ == "__main__":
    sys.exit(main())
