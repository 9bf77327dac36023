"""DepthDataset.summary: one description for every dataset (what ``inpaintenv info`` prints)."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset, SyntheticStreets


@pytest.fixture
def frames() -> ArrayDataset:
    arr = np.zeros((4, 8, 8), np.float32)
    arr[:, :4] = 10.0  # the top half measured: density exactly 0.5
    return ArrayDataset(arr, groups=["a", "a", "a", "b"])


def test_summary_of_any_dataset(frames):
    s = frames.summary(n_sample=4)
    assert s["source"] == "ArrayDataset"
    assert s["frames"] == 4 and s["drives"] == 2
    assert s["frames_per_drive"] == {"a": 3, "b": 1}
    assert s["frame_shape"] == [8, 8]
    assert s["valid_density"] == pytest.approx(0.5)
    assert s["sampled_frames"] == 4


def test_summary_of_a_subset_counts_its_own_frames(frames):
    s = frames[[0, 3]].summary(n_sample=8)
    assert s["frames"] == 2 and s["frames_per_drive"] == {"a": 1, "b": 1}
    assert s["sampled_frames"] == 2  # never more than the frames there are


def test_summary_without_sampling(frames):
    s = frames.summary(n_sample=0)
    assert s["valid_density"] is None and s["sampled_frames"] == 0


@pytest.mark.parametrize("bad", [-1, 1.5, True, "3"])
def test_summary_rejects_bad_sample_counts(frames, bad):
    with pytest.raises(ValueError, match="n_sample"):
        frames.summary(n_sample=bad)


def test_source_specific_fields_come_first():
    s = SyntheticStreets(n=2, seed=3).summary(n_sample=1)
    assert list(s)[:3] == ["source", "seed", "kind"]
    assert s["source"] == "SyntheticStreets" and s["seed"] == 3
