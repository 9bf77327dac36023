"""Estimator parameters as comparable values (imported by test modules)."""

from __future__ import annotations

from typing import Any


def param_values(value: Any) -> Any:
    """``value`` with every estimator in it (an ensemble's members, cloned with it) replaced by
    its class and parameters, so two estimators compare by what they hold, not by identity."""
    if hasattr(value, "get_params"):
        return type(value), param_values(value.get_params(deep=False))
    if isinstance(value, dict):
        return {k: param_values(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(param_values(v) for v in value)
    return value
