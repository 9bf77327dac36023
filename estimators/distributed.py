"""Multi-process training: a thin re-export of :mod:`estimators.learned.distributed`.

Kept so that ``torchrun --nproc_per_node=N -m estimators.distributed ...`` (the command the
docs show) keeps working; the code lives in ``estimators/learned/``.
"""

from .learned.distributed import main, rank_order, train_distributed

__all__ = ["main", "rank_order", "train_distributed"]

if __name__ == "__main__":
    raise SystemExit(main())
