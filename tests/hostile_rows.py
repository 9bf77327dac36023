"""Hand-edited rows of a benchmark's row file: each is no row of the run that resumes it.

:data:`HOSTILE_ROWS` maps a name to ``(edit, says)``: ``edit(lines)`` takes the row file's
rows (dicts, in file order) and returns the lines to write back (dicts or raw strings);
``says`` is what the one-line refusal must name (a regular expression). The benchmark's
resume tests, the Dask resume tests and the entry-point table all use this one table.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

Edit = Callable[[list[dict[str, Any]]], list[Any]]


def _set(**values: Any) -> Edit:
    """The first row with ``values`` in it."""
    return lambda rows: [{**rows[0], **values}, *rows[1:]]


HOSTILE_ROWS: dict[str, tuple[Edit, str]] = {
    "negative-rmse": (_set(hole_rmse=-5.0), r"hole_rmse is -5\.0"),
    "nan-rmse": (_set(hole_rmse=float("nan")), r"hole_rmse is null \(NaN\) although .* scored pixels"),
    "null-metric": (_set(all_mae=None), r"all_mae is null"),
    "infinite-error": (_set(hole_irmse=float("inf")), r"hole_irmse is inf"),
    "psnr-out-of-range": (_set(hole_psnr=500.0), r"hole_psnr (is )?500\.0"),
    "psnr-not-its-rmse": (_set(hole_psnr=20.0), r"hole_psnr 20\.0 is not the PSNR"),
    "negative-count": (_set(hole_count=-1), r"hole_count must be a whole number >= 0"),
    "count-above-frame": (_set(hole_count=10**9, unmeasured_count=10**9), r"exceeds all_count"),
    "fraction-above-one": (_set(hole_fraction=1.5), r"hole_fraction"),
    "seed-true": (_set(seed=True), r"seed must be a whole number"),
    "index-string": (_set(index="0"), r"index must be a whole number"),
    "method-number": (_set(method=7), r"method must be a non-empty string"),
    "duplicate-other-protocol": (lambda rows: [*rows, {**rows[0], "protocol": "freeform-v1"}],
                                 r"protocol 'freeform-v1' is not one this run planned"),
    "duplicate-key": (lambda rows: [*rows, {**rows[0], "ms": 0.5}], r"a second row of method"),
    "duplicate-identical": (lambda rows: [*rows, rows[0]], r"a second row of method"),
    "made-up-drive": (_set(drive="2099_01_01_drive_9999_sync"), r"drive '2099_01_01_drive_9999_sync' is not frame 0's"),
    "made-up-frame": (_set(frame_id="x/0000000099"), r"frame_id 'x/0000000099' is not frame 0's"),
    "unplanned-index": (lambda rows: [*rows, {**rows[0], "index": 999}], r"index 999 is not one this run planned"),
    "unplanned-seed": (lambda rows: [*rows, {**rows[0], "seed": 7}], r"seed 7 is not one this run planned"),
    "other-method": (_set(method="nearest"), r"method 'nearest' is not one this run planned"),
    "other-input": (_set(input_kind="scan"), r"input_kind 'scan' is not one this run planned"),
    "unknown-input": (_set(input_kind="hologram"), r"input_kind 'hologram' is not one this run planned"),
    "extra-key": (_set(score_bonus=1.0), r"unknown column 'score_bonus'"),
    "missing-key": (lambda rows: [{k: v for k, v in rows[0].items() if k != "all_rmse"}, *rows[1:]],
                    r"missing column 'all_rmse'"),
    "not-an-object": (lambda rows: [*rows, [1, 2, 3]], r"a row is a JSON object"),
    "huge-column-name": (_set(**{"k" * 100_000: 1}), r"unknown column 'k+\.\.\. \(100002 characters\)"),
}


def tamper_rows(path: Path, edit: Edit) -> None:
    """Rewrite the row file ``path`` through ``edit``."""
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    path.write_text("".join((line if isinstance(line, str) else json.dumps(line)) + "\n" for line in edit(rows)))


def hole_without_truth(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The first row as a frame whose hole holds no ground truth scores it (a legitimate row):
    hole and unmeasured metrics null, their counts 0 (a map input: its unmeasured pixels are the hole's)."""
    empty = {c: None for c in rows[0] if c.split("_")[0] in ("hole", "unmeasured") and c != "hole_fraction"}
    return [{**rows[0], **empty, "hole_count": 0, "unmeasured_count": 0}, *rows[1:]]
