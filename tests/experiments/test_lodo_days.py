"""experiments/lodo_days.sh: the folds it trains and scores, with ``inpaintenv`` replaced by a recorder."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "lodo_days.sh"

# Records each call's arguments (one line, tab-separated) and writes the model a real
# `train` would, so the script's "already trained" check sees it.
RECORDER = f"""#!{sys.executable}
import os, sys
from pathlib import Path
args = sys.argv[1:]
with open(os.environ["LODO_CALLS"], "a") as f:
    f.write("\\t".join(args) + "\\n")
if args[0] == "train":
    model = Path(args[args.index("--out") + 1]) / "model"
    model.mkdir(parents=True, exist_ok=True)
    (model / "config.json").write_text("{{}}")
"""


def _run(kitti_root: Path, tmp_path: Path, *args: str, **env_vars: str) -> list[list[str]]:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    fake = bin_dir / "inpaintenv"
    fake.write_text(RECORDER)
    fake.chmod(fake.stat().st_mode | stat.S_IEXEC)
    calls = tmp_path / "calls.txt"
    calls.write_text("")
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}", "LODO_CALLS": str(calls),
           "BENCH_FLAGS": "-m kitti-mixed-v1", **env_vars}
    subprocess.run(["bash", str(SCRIPT), str(kitti_root), str(tmp_path / "out"), *args], env=env, check=True,
                   capture_output=True, text=True)
    return [line.split("\t") for line in calls.read_text().splitlines()]


def test_every_preset_trained_per_fold_and_scored_in_one_run(kitti_root, tmp_path):
    from inpaintenv.data import KittiDepth

    days = sorted({str(g)[:10] for g in KittiDepth(kitti_root, split="train").groups})
    calls = _run(kitti_root, tmp_path, "context-kitti,study-unet-tv:300", "0")
    trains = [c for c in calls if c[0] == "train"]
    benches = [c for c in calls if c[0] == "benchmark"]
    assert len(trains) == 2 * (len(days) + 1)           # two presets, each day and drive 0001
    assert len(benches) == len(days) + 2                # each fold, then val
    for call in trains:
        steps = call[call.index("--preset") + 1] == "study-unet-tv"
        assert ("--max-steps" in call) == steps and (not steps or call[call.index("--max-steps") + 1] == "300")
    trained = {f"{c[c.index('--out') + 1]}/model" for c in trains}
    for call in benches:
        assert call.count("--checkpoint") == 2 and "--suite" in call and call[-2:] == ["-m", "kitti-mixed-v1"]
        scored = [call[i + 1].split("=", 1)[1] for i, a in enumerate(call) if a == "--checkpoint"]
        assert set(scored) <= trained  # every model scored is one the script trained
        assert call[call.index("--seed") + 1] == "0" and call.count("--seed") == 1
    # Rerunning trains nothing again and scores every fold again (the benchmark resumes).
    again = _run(kitti_root, tmp_path, "context-kitti,study-unet-tv:300", "0")
    assert [c[0] for c in again] == ["benchmark"] * len(benches)


def test_an_empty_suite_scores_only_the_fold_models_and_bench_flags(kitti_root, tmp_path):
    calls = _run(kitti_root, tmp_path, "context-kitti", "0", SUITE="", BENCH_FLAGS="-m harmonic")
    benches = [c for c in calls if c[0] == "benchmark"]
    assert benches and all("--suite" not in c and c[-2:] == ["-m", "harmonic"] for c in benches)
    named = _run(kitti_root, tmp_path, "context-kitti", "0", SUITE="fast")
    assert all(c[c.index("--suite") + 1] == "fast" for c in named if c[0] == "benchmark")


def test_train_jobs_trains_every_fold_before_any_benchmark(kitti_root, tmp_path):
    calls = _run(kitti_root, tmp_path, "context-kitti", "0", TRAIN_JOBS="2")
    kinds = [c[0] for c in calls]
    trains = kinds.count("train")
    assert trains == len({c[c.index("--out") + 1] for c in calls if c[0] == "train"}) > 1
    assert kinds == ["train"] * trains + ["benchmark"] * (len(kinds) - trains)
