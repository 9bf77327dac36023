"""Fitted stand-ins of a fill, shared by the interval tests (calibration, leave-one-day-out)."""

from __future__ import annotations

import numpy as np


class FillTen:
    """A fitted base filling every NaN with 10 m (measured pixels kept): residuals are the truth's noise."""

    def __sklearn_is_fitted__(self) -> bool:
        return True

    def predict(self, X):
        x = np.asarray(X, dtype=np.float32)
        return np.where(np.isnan(x), np.float32(10.0), x)


class FoldTen(FillTen):
    """A fold model of FillTen's recipe that records the drives it was trained on."""

    def __init__(self, seen: list[str]) -> None:
        self.training_drives_ = seen
