"""Depth inpainting methods as scikit-learn estimators.

Classical methods import without torch; the neural ones load torch on first use.
"""

from __future__ import annotations

from .base import BaseInpainter

__all__ = ["BaseInpainter"]
