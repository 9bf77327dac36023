#!/usr/bin/env bash
# Leave-one-day-out and leave-drive-0001-out check of a training preset with the
# project's own commands (issue: a scene prior that carries to unseen days and to
# official maps).
#
#   bash experiments/lodo_days.sh <KITTI root> [OUT] [PRESETS] [SEED ...]
#
# For every recording day D of the train split: train each preset on the other days'
# drives (both cameras where a drive has them) and score D's drives against every
# classical method. Then train without drive 2011_09_26_drive_0001_sync (official KITTI
# maps) and score both of its cameras, and score the val frames with those models as a
# check. OUT defaults to lodo-days, PRESETS to context-kitti, seeds to 0 1.
#
# PRESETS is a comma-separated list; an entry NAME:N trains NAME with --max-steps N (the
# step-based presets, e.g. the study's U-Net at a CPU budget):
#   bash experiments/lodo_days.sh <KITTI root> lodo-days context-kitti,study-unet-tv:300,study-autoencoder:300
# All of a fold's models are scored in one benchmark run, so they share the classical rows.
# Each benchmark prints the study-style table and the headline "learned / strongest
# classical" with its paired 95 % interval; rows land in OUT/bench-<fold>/results.json
# (experiments/fold_ensemble.py pooled pools a fold's drives). Rerunning resumes.
# TRAIN_FLAGS adds options to every `inpaintenv train` (e.g. "--threads 1 --jobs 1" beside
# other work); BENCH_FLAGS to every `inpaintenv benchmark` (e.g. "-m kitti-mixed-v1").
# TRAIN_JOBS=N trains the folds' models N at a time (separate processes) before any benchmark
# runs, e.g. TRAIN_JOBS=2 TRAIN_FLAGS="--threads 1 --jobs 1" on 2 cores; default 1, in turn.
# SUITE names the benchmark suite (default classical); SUITE= (empty) scores only the
# fold models and BENCH_FLAGS' methods, e.g. a speed check of trained folds against harmonic:
#   SUITE= BENCH_FLAGS="-m harmonic" bash experiments/lodo_days.sh <KITTI root> lodo-speed
# (with OUT/train-* linked to an earlier run's folders, nothing is trained again).
set -euo pipefail
ROOT=${1:?usage: bash experiments/lodo_days.sh <KITTI root> [OUT] [PRESETS] [SEED ...]}
OUT=${2:-lodo-days}
IFS=, read -r -a PRESETS <<< "${3:-context-kitti}"
shift $(( $# >= 3 ? 3 : $# ))
SEEDS=("${@:-0 1}")
read -r -a SEEDS <<< "${SEEDS[*]}"
SEED_FLAGS=()
for s in "${SEEDS[@]}"; do SEED_FLAGS+=(--seed "$s"); done
OFFICIAL=2011_09_26_drive_0001_sync
SUITE=${SUITE-classical}
SUITE_FLAGS=()
if [ -n "$SUITE" ]; then SUITE_FLAGS=(--suite "$SUITE"); fi

# One line per recording day of the train split: the day, then its drives (one Python start).
DAY_DRIVES=$(python -c "
from inpaintenv.data import KittiDepth
drives = sorted({str(g) for g in KittiDepth('$ROOT', split='train').groups})
for day in sorted({d[:10] for d in drives}):
    print(day, *[d for d in drives if d.startswith(day)])")

checkpoints() {  # sets CHECKPOINTS: a --checkpoint flag for each preset's model of fold $1
  local ENTRY PRESET
  CHECKPOINTS=()
  for ENTRY in "${PRESETS[@]}"; do
    PRESET=${ENTRY%%:*}
    CHECKPOINTS+=(--checkpoint "$PRESET-without-$1=$OUT/train-$1-$PRESET/model")
  done
}

train_fold() {  # fold name, drives to leave out (space-separated): train each preset once
  local NAME=$1 HELD=$2 ENTRY PRESET STEPS
  for ENTRY in "${PRESETS[@]}"; do
    PRESET=${ENTRY%%:*}
    STEPS=()
    if [ "$ENTRY" != "$PRESET" ]; then STEPS=(--max-steps "${ENTRY#*:}"); fi
    if [ ! -f "$OUT/train-$NAME-$PRESET/model/config.json" ]; then
      # shellcheck disable=SC2086
      inpaintenv train --preset "$PRESET" --kitti-root "$ROOT" --split train --camera both \
        --exclude-drives $HELD "${STEPS[@]}" --out "$OUT/train-$NAME-$PRESET" --quiet ${TRAIN_FLAGS:-}
    fi
  done
}

fold() {  # fold name, drives to leave out and score (space-separated), camera to score
  local NAME=$1 HELD=$2 CAMERA=$3
  train_fold "$NAME" "$HELD"
  checkpoints "$NAME"
  # shellcheck disable=SC2086
  inpaintenv benchmark --kitti-root "$ROOT" --split train --camera "$CAMERA" --drives $HELD --holdout 0 \
    "${SUITE_FLAGS[@]}" "${CHECKPOINTS[@]}" "${SEED_FLAGS[@]}" --figure-frames 0 --out "$OUT/bench-$NAME" \
    ${BENCH_FLAGS:-}
}

# The folds, listed once: name, drives left out and scored, camera scored.
FOLD_NAMES=() FOLD_HELD=() FOLD_CAMERAS=()
while read -r D HELD; do
  if [ -n "$D" ]; then FOLD_NAMES+=("day-$D") FOLD_HELD+=("$HELD") FOLD_CAMERAS+=(image_02); fi
done <<< "$DAY_DRIVES"
FOLD_NAMES+=(drive-0001) FOLD_HELD+=("$OFFICIAL") FOLD_CAMERAS+=(both)

TRAIN_JOBS=${TRAIN_JOBS:-1}
if [ "$TRAIN_JOBS" -gt 1 ]; then  # every fold's training first, TRAIN_JOBS at a time
  for i in "${!FOLD_NAMES[@]}"; do
    while [ "$(jobs -pr | wc -l)" -ge "$TRAIN_JOBS" ]; do wait -n; done
    train_fold "${FOLD_NAMES[i]}" "${FOLD_HELD[i]}" &
  done
  while [ "$(jobs -pr | wc -l)" -gt 0 ]; do wait -n || exit 1; done
fi

for i in "${!FOLD_NAMES[@]}"; do
  fold "${FOLD_NAMES[i]}" "${FOLD_HELD[i]}" "${FOLD_CAMERAS[i]}"
done
# The val frames (official maps of other drives), scored by the models trained without 0001.
checkpoints drive-0001
# shellcheck disable=SC2086
inpaintenv benchmark --kitti-root "$ROOT" --split val --holdout 0 "${SUITE_FLAGS[@]}" "${CHECKPOINTS[@]}" \
  "${SEED_FLAGS[@]}" --figure-frames 0 --out "$OUT/bench-val" ${BENCH_FLAGS:-}
