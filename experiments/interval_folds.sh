#!/usr/bin/env bash
# The interval calibration of kitti-ensemble-v1 and its leave-one-day-out check.
#
#   bash experiments/interval_folds.sh <KITTI root> [OUT]
#
# 1. Trains the release's recipe (preset kitti-ensemble-v1) three times, each without one
#    recording day AND without a few small drives of the other days kept for calibration
#    (a fold model may be calibrated only on drives it never saw), two at a time with one
#    thread each (~50 min on 2 cores), into OUT/train-day-<DAY>.
# 2. Scores their 90 % intervals on the left-out day (and drive 0001's official maps with the
#    2011_09_26 model), calibrated on the fold's held-out drives:
#    perf/interval_lodo.py, rows in OUT/lodo-learned.json.
# 3. Writes the shipped calibration, estimators/pretrained/intervals/kitti-ensemble-v1.json:
#    every drive but 0001 (official maps, never calibrated on) scored by the fold model trained without its day
#    (experiments/interval_calibration.py calibrate).
# Rerunning skips the trained folds.
set -euo pipefail
ROOT=${1:?usage: bash experiments/interval_folds.sh <KITTI root> [OUT]}
OUT=${2:-interval-folds}
HERE=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$OUT"
drives_of_day() {
  python -c "
from inpaintenv.data import KittiDepth
print(' '.join(sorted({str(g) for g in KittiDepth('$ROOT', split='train').groups if str(g).startswith('$1')})))"
}
D26=$(drives_of_day 2011_09_26) D30=$(drives_of_day 2011_09_30) D03=$(drives_of_day 2011_10_03)
# Calibration drives: the small drives of the other days (few training frames lost).
CAL26="2011_09_30_drive_9018_sync 2011_09_30_drive_9020_sync 2011_10_03_drive_9027_sync"
CAL30="2011_09_26_drive_9002_sync 2011_09_26_drive_9009_sync 2011_09_26_drive_9067_sync 2011_10_03_drive_9027_sync"
CAL03="2011_09_26_drive_9002_sync 2011_09_26_drive_9009_sync 2011_09_26_drive_9067_sync 2011_09_30_drive_9018_sync 2011_09_30_drive_9020_sync"
train() {  # day, drives to leave out
  if [ ! -f "$OUT/train-day-$1/model/config.json" ]; then
    # shellcheck disable=SC2086
    inpaintenv train --preset kitti-ensemble-v1 --kitti-root "$ROOT" --split train --camera both \
      --threads 1 --jobs 1 --quiet --exclude-drives $2 --out "$OUT/train-day-$1"
  fi
}
train 2011_09_30 "$D30 $CAL30" &
train 2011_10_03 "$D03 $CAL03" &
wait
train 2011_09_26 "$D26 $CAL26"
python "$HERE/perf/interval_lodo.py" --kitti-root "$ROOT" --spread-method scanline \
  --checkpoint day-2011_09_26="$OUT/train-day-2011_09_26/model" \
  --checkpoint day-2011_09_30="$OUT/train-day-2011_09_30/model" \
  --checkpoint day-2011_10_03="$OUT/train-day-2011_10_03/model" \
  --checkpoint drive-0001="$OUT/train-day-2011_09_26/model" --json "$OUT/lodo-learned.json"
python "$HERE/experiments/interval_calibration.py" calibrate --kitti-root "$ROOT" \
  --fold 2011_09_26="$OUT/train-day-2011_09_26/model" --fold 2011_09_30="$OUT/train-day-2011_09_30/model" \
  --fold 2011_10_03="$OUT/train-day-2011_10_03/model"
