"""Every estimator the shared suite (``test_common.py``) runs on: one flat list.

Append a small, fast configuration of any new estimator here (e.g. a tiny neural
net trained for one epoch). Ids in the test report are the instances' reprs.
"""

from __future__ import annotations

from estimators.classical import (
    ConstantInpainter,
    HarmonicInpainter,
    IPBasicInpainter,
    IterativeBilateralInpainter,
    NavierStokesInpainter,
    NearestInpainter,
    ScanlineInpainter,
    TeleaInpainter,
)
from estimators.learned import (  # imports torch here
    AutoencoderInpainter,
    BlendInpainter,
    ContextBlendInpainter,
    MeanEnsembleInpainter,
    PriorUNetInpainter,
    UNetInpainter,
)

ESTIMATORS = [
    TeleaInpainter(),
    TeleaInpainter(fill="hole", radius=3),
    NavierStokesInpainter(),
    NavierStokesInpainter(fill="hole"),
    IterativeBilateralInpainter(iterations=3),
    IterativeBilateralInpainter(iterations=3, fill="hole"),
    IPBasicInpainter(),
    IPBasicInpainter(fallback="nearest", blur="bilateral", extrapolate=True),
    IPBasicInpainter(fallback="scanline", blur="none"),
    NearestInpainter(),
    HarmonicInpainter(),
    ScanlineInpainter(),
    ScanlineInpainter(inverse=True, vertical=True),
    ConstantInpainter(),
    # Tiny neural nets (one epoch, one thread) so the shared suite stays fast. depth=1:
    # scikit-learn's checks fit on (n_samples, 2) arrays, read as 2-pixel-wide frames,
    # and fit refuses frames narrower than 2**depth.
    UNetInpainter(width=4, depth=1, batch_size=2, epochs=1, random_state=0, num_threads=1),
    AutoencoderInpainter(width=4, depth=1, batch_size=2, epochs=1, input_mask=True, depth_scale="frame", random_state=0, num_threads=1),
    PriorUNetInpainter(width=4, levels=1, batch_size=2, max_steps=2, random_state=0, num_threads=1),
    BlendInpainter(width=4, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=50, batch_pixels=64,
                   num_threads=1),
    ContextBlendInpainter(n_context=2, context_widths=(4, 4), width=4, layers=1, epochs=1, masks_per_frame=1,
                          keep=(1.0,), pixels_per_frame=50, batch_frames=2, batch_pixels=32, num_threads=1),
]

ESTIMATORS.append(MeanEnsembleInpainter([("context", ESTIMATORS[-1]), ("blend", ESTIMATORS[-2])]))
