"""Versioned protocols never change behaviour: pinned fingerprints of a few masks.

If one of these fails, a change altered what an existing protocol draws. Do not update
the fingerprint: restore the old behaviour and put the new one in a new version
(e.g. ``freeform-v2``). Only a NumPy change to its random streams may justify an
update, and that must be recorded in docs/protocols.md.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from inpaintenv.masks import get_protocol

GOLDEN = {
    "rect-v1": "c892b37ab57c5b8f",
    "lidar-dropout-v1": "11ef1fb50d10bf8b",
    "ego-occlusion-v1": "aa66c676d4eca1ff",
    "freeform-v1": "d6ae45301b122ea0",
    "mixed-v1": "6604d76d35bc9568",
    "densify-v1": "00771d0490d50d2d",
}


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_fingerprint(name):
    proto = get_protocol(name)
    h = hashlib.sha256()
    for i in range(3):
        h.update(np.packbits(proto.mask((88, 304), seed=0, index=i)).tobytes())
    assert h.hexdigest()[:16] == GOLDEN[name]
