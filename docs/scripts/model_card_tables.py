"""Write (or check) the parameter tables of the model cards from the shipped release files.

Run from the project root::

    python docs/scripts/model_card_tables.py           # rewrite the tables in docs/model_cards/
    python docs/scripts/model_card_tables.py --check   # exit 1 if a card differs from its release

A card marks where a release family's table goes with two HTML comments::

    <!-- release-table: kitti-rect-v1 kitti-rect-v2 kitti-rect-v3 -->
    ...generated table...
    <!-- /release-table -->

The table is rendered from ``estimators/pretrained/<name>.json`` (class, every parameter,
trained steps, seed, weights checksum) and the header of ``<name>.safetensors`` (tensor
shapes, so the parameter count needs no torch), so a card cannot drift from the weights
it describes: ``tests/docs/test_model_cards.py`` regenerates every table and compares.
"""

from __future__ import annotations

import argparse
import json
import re
import struct
import sys
from collections.abc import Sequence
from math import prod
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PRETRAINED = ROOT / "estimators" / "pretrained"
CARDS = ROOT / "docs" / "model_cards"

BLOCK = re.compile(r"(<!-- release-table: (?P<names>[^>]*?) -->\n)(?P<body>.*?)(<!-- /release-table -->)",
                   flags=re.DOTALL)


def release_config(name: str, folder: Path = PRETRAINED) -> dict:
    """The parsed ``<name>.json`` of a shipped release.

    Parameters
    ----------
    name : str
        Release name, e.g. ``"kitti-rect-v3"``.
    folder : Path
        Folder holding the release files.

    Returns
    -------
    dict
        The release's configuration (``class``, ``params``, ``seed``, ``fitted``, ``weights_sha256``).
    """
    path = folder / f"{name}.json"
    if not path.is_file():
        raise FileNotFoundError(f"no release {name!r}: {path} does not exist")
    return json.loads(path.read_text())


def tensor_shapes(path: Path) -> dict[str, list[int]]:
    """Tensor name -> shape, read from a safetensors file's JSON header (no torch needed).

    Parameters
    ----------
    path : Path
        A ``.safetensors`` file.

    Returns
    -------
    dict of str to list of int
    """
    with path.open("rb") as f:
        (n,) = struct.unpack("<Q", f.read(8))
        header = json.loads(f.read(n))
    return {k: v["shape"] for k, v in header.items() if k != "__metadata__"}


def _cell(value: object) -> str:
    if isinstance(value, (list, tuple)):
        return ", ".join(str(v) for v in value)
    return json.dumps(value) if isinstance(value, (bool, type(None))) else str(value)


def release_rows(name: str, folder: Path = PRETRAINED) -> dict[str, str]:
    """Row label -> table cell for one release, in table order.

    Parameters
    ----------
    name : str
        Release name.
    folder : Path
        Folder holding ``<name>.json`` and ``<name>.safetensors``.

    Returns
    -------
    dict of str to str
    """
    config = release_config(name, folder)
    weights = folder / f"{name}.safetensors"
    shapes = tensor_shapes(weights)
    rows = {
        "class": f"`{config['class']}`",
        "weights file": f"`estimators/pretrained/{name}.safetensors` ({weights.stat().st_size:,} bytes)",
        "weights SHA-256": f"`{config['weights_sha256'][:16]}…`",
        "parameters (weights)": f"{sum(prod(s) for s in shapes.values()):,} in {len(shapes)} tensors",
        "optimiser steps trained": str(config.get("fitted", {}).get("n_steps_", "–")),
        "seed": str(config.get("seed", "–")),
    }
    if "members" in config:  # a MeanEnsembleInpainter: each member's rows, its parameters as name__param
        rows.pop("optimiser steps trained")
        rows.pop("seed")
        for member in config["members"]:
            name, own = member["name"], member["config"]
            fit = own.get("fit", {})
            rows[f"member `{name}`"] = f"`{own['class']}`, seed {own['params'].get('random_state', '–')}, " + (
                f"{fit['training_frames']:,} frames / {fit['n_pixels']:,} pixels" if "n_pixels" in fit else "")
        for member in config["members"]:
            rows.update({f"`{member['name']}__{k}`": f"`{_cell(v)}`"
                         for k, v in sorted(member["config"]["params"].items())})
    elif "fit" in config:  # a BlendInpainter: trained on pooled pixel samples, seeded by random_state
        rows.pop("optimiser steps trained")
        rows["seed"] = str(config["params"].get("random_state", "–"))
        rows["training frames / pixels"] = f"{config['fit']['training_frames']:,} / {config['fit']['n_pixels']:,}"
    rows.update({f"`{k}`": f"`{_cell(v)}`" for k, v in sorted(config["params"].items())})
    return rows


def render_table(names: Sequence[str], folder: Path = PRETRAINED) -> str:
    """The Markdown table of one or more releases, one column per release.

    Parameters
    ----------
    names : sequence of str
        Release names, in column order.
    folder : Path
        Folder holding the release files.

    Returns
    -------
    str
        Markdown table ending with a newline.
    """
    columns = [release_rows(n, folder) for n in names]
    labels = list(dict.fromkeys(label for col in columns for label in col))
    lines = ["| | " + " | ".join(f"`{n}`" for n in names) + " |",
             "|---|" + "---|" * len(names)]
    lines += [f"| {label} | " + " | ".join(col.get(label, "–") for col in columns) + " |" for label in labels]
    return "\n".join(lines) + "\n"


def card_releases(text: str) -> list[list[str]]:
    """The release names of every generated table in a card's text.

    Parameters
    ----------
    text : str
        A model card's Markdown.

    Returns
    -------
    list of list of str
        One list of names per table, in order.
    """
    return [m["names"].split() for m in BLOCK.finditer(text)]


def regenerate(text: str, folder: Path = PRETRAINED) -> str:
    """A card's text with every generated table rendered again from the release files.

    Parameters
    ----------
    text : str
        A model card's Markdown.
    folder : Path
        Folder holding the release files.

    Returns
    -------
    str
    """
    return BLOCK.sub(lambda m: m[1] + render_table(m["names"].split(), folder) + m[4], text)


def main(argv: Sequence[str] | None = None) -> int:
    """Rewrite or check every card under ``docs/model_cards/``; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only report cards that differ; exit 1 if any")
    args = parser.parse_args(argv)
    stale = []
    for card in sorted(CARDS.glob("*.md")):
        text = card.read_text()
        new = regenerate(text)
        if new != text:
            stale.append(card)
            if not args.check:
                card.write_text(new)
    for card in stale:
        print(f"{'stale' if args.check else 'rewrote'}: {card.relative_to(ROOT)}")
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
