#!/usr/bin/env bash
# Leave-one-drive-out check of the shipped recipe (preset blend-kitti, release kitti-rect-v4)
# with the project's own commands: for every train drive D, train on the other train drives
# and score D against every classical method; then score the shipped release and the
# classical methods on the val frames (official KITTI maps, never trained on): the default suite.
#
#   bash experiments/lodo.sh <KITTI root> [OUT] [SEED ...]
#
# OUT defaults to lodo-runs; seeds default to 0 1. Each benchmark prints the study-style
# table and the headline "best learned / strongest classical per drive" with its paired
# 95 % interval; the rows land in OUT/bench-<drive>/results.json. Rerunning resumes.
set -euo pipefail
ROOT=${1:?usage: bash experiments/lodo.sh <KITTI root> [OUT] [SEED ...]}
OUT=${2:-lodo-runs}
shift $(( $# >= 2 ? 2 : $# ))
SEEDS=("${@:-0 1}")
read -r -a SEEDS <<< "${SEEDS[*]}"
SEED_FLAGS=()
for s in "${SEEDS[@]}"; do SEED_FLAGS+=(--seed "$s"); done

DRIVES=$(python -c "
from inpaintenv.data import KittiDepth
print(' '.join(sorted({str(g) for g in KittiDepth('$ROOT', split='train').groups})))")

for D in $DRIVES; do
  if [ ! -f "$OUT/train-$D/model/config.json" ]; then
    inpaintenv train --preset blend-kitti --kitti-root "$ROOT" --split train --exclude-drives "$D" \
      --out "$OUT/train-$D" --quiet
  fi
  inpaintenv benchmark --kitti-root "$ROOT" --split train --drives "$D" --holdout 0 --suite classical \
    --checkpoint "blend-without-$D=$OUT/train-$D/model" "${SEED_FLAGS[@]}" --figure-frames 0 \
    --out "$OUT/bench-$D"
done

# The default suite: the shipped learned releases beside every classical method.
inpaintenv benchmark --kitti-root "$ROOT" --split val --holdout 0 "${SEED_FLAGS[@]}" --figure-frames 0 \
  --out "$OUT/bench-val"
