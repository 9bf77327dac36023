"""Join saved learned models into one MeanEnsembleInpainter checkpoint, e.g. two fold models of a fold.

``inpaintenv train --preset ensemble-kitti`` trains both members of the ensemble on the same
frames, one after the other. Where each member's recipe was already trained on a fold (two
runs of ``experiments/lodo_days.sh``, one per preset), joining the two saved models gives the
ensemble of that fold without training again: each member is the model its own preset trains.
The joined folder loads with ``inpaintenv benchmark --checkpoint NAME=OUT``.

Examples
--------
    python experiments/join_models.py --out lodo-ensemble/train-day-2011_10_03-ensemble-kitti/model \\
        context=lodo-draws-s1/train-day-2011_10_03-context-kitti-draws/model \\
        blend=lodo-blend/train-day-2011_10_03-blend-kitti/model --set blend__tta=false
"""

from __future__ import annotations

import argparse
import json
import sys

from estimators import MeanEnsembleInpainter
from estimators.learned import load_checkpoint


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("members", nargs="+", metavar="NAME=FOLDER", help="a member's name and saved model folder")
    p.add_argument("--out", required=True, help="folder of the joined checkpoint")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="a prediction parameter, VALUE in JSON: the ensemble's or a member's as name__key "
                        "(e.g. blend__tta=false; repeatable)")
    args = p.parse_args(argv)
    members = []
    for item in args.members:
        name, sep, folder = item.partition("=")
        if not sep or not name or not folder:
            p.error(f"a member is NAME=FOLDER, got {item!r}")
        try:
            members.append((name, load_checkpoint(folder)))
        except (ValueError, OSError) as exc:  # not a model folder, or an unreadable one
            p.error(f"member {name}: {exc}")
    try:
        est = MeanEnsembleInpainter.from_fitted(members)
        for item in args.set:
            key, sep, value = item.partition("=")
            if not sep:
                p.error(f"--set takes KEY=VALUE, got {item!r}")
            est.set_params(**{key: json.loads(value)})
    except (ValueError, TypeError) as exc:
        p.error(str(exc))
    print(f"joined {', '.join(n for n, _ in members)} -> {est.save(args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
