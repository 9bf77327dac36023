"""``inpaintenv info``: frames, drives, sizes and valid-pixel density of a data source,
and the protocols and methods there are."""

from __future__ import annotations

import argparse
import json
from typing import Any

from ..data.base import as_dataset
from ..data.inputs import INPUT_KINDS, INPUTS
from .options import add_common_options, add_source_options, open_source_from_args
from ..exceptions import InvalidInputError

__all__ = ["add_info", "cmd_info", "describe_source", "input_kinds", "protocol_inputs"]


def add_info(subparsers: Any) -> None:
    p = subparsers.add_parser("info", help="summarise a data source", description="Summarise a data source: frames, drives, sizes, valid-pixel density.")
    add_source_options(p)
    add_common_options(p)
    p.add_argument("--sample", type=int, default=8, help="frames decoded to measure density (default 8)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_info)


def describe_source(ds: Any, n_sample: int = 8) -> dict[str, Any]:
    """``ds.summary()`` for ``inpaintenv info``, with ``--sample`` checked first."""
    if n_sample < 1:
        raise InvalidInputError(f"--sample must be >= 1, got {n_sample}")
    return dict(as_dataset(ds).summary(n_sample=n_sample))


def _kinds_words(kinds: list[str]) -> str:
    """``"scan"`` for every scan kind (the scan and its density variants), else the kinds joined."""
    return "scan" if kinds == [k for k in INPUT_KINDS if INPUTS[k].separate] else " and ".join(kinds)


def input_kinds() -> dict[str, str]:
    """Each input kind (:data:`~inpaintenv.data.inputs.INPUTS`) and what a method is then given."""
    return {k: INPUTS[k].summary for k in INPUT_KINDS}


def protocol_inputs() -> dict[str, list[str]]:
    """Each protocol and the input kinds it applies to (``densify-v1``, which cuts no hole, to scans only)."""
    from ..masks import available_protocols, get_protocol

    scans = [k for k in INPUT_KINDS if INPUTS[k].separate]
    return {p: scans if get_protocol(p).task == "unmeasured" else list(INPUT_KINDS) for p in available_protocols()}


def cmd_info(args: argparse.Namespace) -> int:
    from ..methods.registry import available_aliases, available_methods

    ds = open_source_from_args(args)
    info = describe_source(ds, args.sample)
    info["frames_used"] = len(ds)
    if args.json:
        info["input_kinds"] = input_kinds()
        info["protocols"] = protocol_inputs()
        info["methods"] = available_methods()
        info["aliases"] = available_aliases()
        print(json.dumps(info, indent=1))
        return 0
    for key, value in info.items():
        if key == "valid_density" and value is not None:
            value = f"{100 * value:.1f} % of pixels (mean over {info.get('sampled_frames', '?')} frames)"
        elif isinstance(value, dict):
            value = ", ".join(f"{k}: {v}" for k, v in value.items())
        print(f"{key:>16}: {value}")
    print(f"{'input kinds':>16}: " + "; ".join(f"{k} ({what})" for k, what in input_kinds().items()))
    print(f"{'protocols':>16}: " + ", ".join(
        p if kinds == list(INPUT_KINDS) else f"{p} ({_kinds_words(kinds)} only)" for p, kinds in protocol_inputs().items()))
    print(f"{'methods':>16}: {', '.join(available_methods())}")
    print(f"{'aliases':>16}: {', '.join(f'{a} -> {t}' for a, t in available_aliases().items())}")
    return 0
