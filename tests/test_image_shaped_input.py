"""Image-shaped arrays are refused with one line on every path that takes depth.

An ``(H, W, 3)`` colour image used to be read as ``H`` frames of ``W x 3`` pixels: predict
returned it filled, metrics and evaluate scored it. The shared check (conventions.check_depth)
now refuses it, so every path below must say the same thing.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators.classical import NearestInpainter
from inpaintenv.data.base import as_dataset
from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.evaluate import evaluate
from inpaintenv.metrics import frame_metrics

COLOUR = r"a trailing size-3 axis looks like colour channels"
NARROW = r"frames of 6x40 pixels, but a depth frame in an \(N, H, W\) batch is at least 8x8"


@pytest.fixture
def image() -> np.ndarray:
    """A KITTI-sized colour image in metres-looking values, with one pixel to fill."""
    x = np.random.default_rng(0).uniform(1.0, 50.0, (352, 1216, 3)).astype(np.float32)
    return x


def test_predict_refuses_a_colour_image(image):
    image[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match=rf"X has shape \(352, 1216, 3\): {COLOUR}"):
        NearestInpainter().predict(image)


def test_predict_refuses_frames_narrower_than_the_minimum():
    x = np.ones((4, 6, 40), np.float32)
    x[:, 0, 0] = np.nan
    with pytest.raises(ValueError, match=NARROW):
        NearestInpainter().predict(x)


def test_metrics_refuse_a_colour_image(image):
    with pytest.raises(ValueError, match=rf"ground truth has shape \(352, 1216, 3\): {COLOUR}"):
        frame_metrics(image, image, np.zeros(image.shape, bool))


def test_evaluate_refuses_a_colour_image_as_source(image):
    with pytest.raises(ValueError, match=COLOUR):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), image, n_frames=1, progress=False)


def test_env_and_datasets_refuse_a_colour_image(image):
    with pytest.raises(ValueError, match=COLOUR):
        DepthInpaintEnv(image)
    with pytest.raises(ValueError, match=COLOUR):
        as_dataset(image)
    with pytest.raises(ValueError, match=NARROW):
        as_dataset(np.ones((4, 6, 40), np.float32))
