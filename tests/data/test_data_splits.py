"""Drive-level splits, subsets and scikit-learn indexing stay lazy and never mix drives."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from sklearn.base import BaseEstimator
from sklearn.model_selection import GroupKFold, cross_validate
from sklearn.utils import _safe_indexing

from inpaintenv.data import ArrayDataset, ConcatDataset, DepthDataset, Subset, SyntheticStreets, split_by_drive, subset
from inpaintenv.exceptions import InvalidInputError


class CountingStreets(SyntheticStreets):
    """Counts decoded frames, to prove that splitting loads nothing."""

    loads = 0

    def _load(self, index: int) -> np.ndarray:
        type(self).loads += 1
        return super()._load(index)


@pytest.fixture
def ds() -> CountingStreets:
    CountingStreets.loads = 0
    return CountingStreets(n=40, seed=0, frame_shape=(32, 48), frames_per_drive=4)


def test_split_by_drive_never_shares_a_drive(ds):
    train, test = split_by_drive(ds, test_size=0.3, seed=1)
    assert not set(train.groups) & set(test.groups)
    assert len(train) + len(test) == len(ds) and len(np.unique(test.groups)) == 3
    again = split_by_drive(ds, test_size=0.3, seed=1)
    np.testing.assert_array_equal(again[1].indices, test.indices)
    assert CountingStreets.loads == 0


def test_subset_fraction_and_nesting(ds):
    quarter = subset(ds, 0.25, seed=0)
    assert len(quarter) == 10 and (np.diff(quarter.indices) > 0).all()
    np.testing.assert_array_equal(subset(ds, 0.25, seed=0).indices, quarter.indices)
    inner = quarter[[1, 3]]
    assert isinstance(inner, Subset) and inner.parent is ds  # flattened, no chain of views
    np.testing.assert_array_equal(inner.indices, quarter.indices[[1, 3]])
    assert inner.frame_ids == [ds.frame_ids[i] for i in quarter.indices[[1, 3]]]
    assert CountingStreets.loads == 0
    np.testing.assert_array_equal(inner[0], ds[int(quarter.indices[1])])


def test_group_kfold_and_safe_indexing_stay_lazy(ds):
    folds = list(GroupKFold(n_splits=5).split(np.zeros(len(ds)), groups=ds.groups))
    for train_idx, test_idx in folds:
        assert not set(ds.groups[train_idx]) & set(ds.groups[test_idx])
        part = _safe_indexing(ds, test_idx)  # what GridSearchCV / cross_validate do
        assert isinstance(part, Subset) and part.shape == (len(test_idx), 32, 48)
        np.testing.assert_array_equal(part.groups, ds.groups[test_idx])
    assert CountingStreets.loads == 0


class _Probe(BaseEstimator):
    """Records what scikit-learn hands to fit/score."""

    def fit(self, X, y=None):
        assert isinstance(X, Subset)
        self.train_drives_ = set(X.groups)
        return self

    def score(self, X, y=None):
        assert isinstance(X, Subset) and not set(X.groups) & self.train_drives_
        return float(len(X))


def test_cross_validate_passes_lazy_subsets(ds):
    res = cross_validate(_Probe(), ds, groups=ds.groups, cv=GroupKFold(n_splits=5))
    assert res["test_score"].sum() == len(ds)
    assert CountingStreets.loads == 0


def test_datasets_pickle(ds, tmp_path):
    again = pickle.loads(pickle.dumps(ds))
    np.testing.assert_array_equal(again[5], ds[5])
    np.testing.assert_array_equal(again.groups, ds.groups)


def test_splits_refuse_arrays_and_non_integer_seeds(ds):
    arr = np.ones((4, 8, 8), np.float32)
    with pytest.raises(TypeError, match="split_by_drive's dataset must be a DepthDataset, got ndarray; wrap"):
        split_by_drive(arr)
    with pytest.raises(TypeError, match="subset's dataset must be a DepthDataset"):
        subset(arr, 0.5)
    with pytest.raises(TypeError, match="ConcatDataset part 0 must be a DepthDataset, got ndarray"):
        ConcatDataset([arr])
    with pytest.raises(TypeError, match="ConcatDataset needs a list of datasets"):
        ConcatDataset(ds)
    with pytest.raises(TypeError, match="seed must be a non-negative integer, got 0.5"):
        split_by_drive(ds, seed=0.5)
    with pytest.raises(ValueError, match="seed must be a non-negative integer, got -1"):
        subset(ds, 0.5, seed=-1)
    with pytest.raises(TypeError, match="fraction must be a number"):
        subset(ds, "0.5")
    with pytest.raises(TypeError, match="test_size"):
        split_by_drive(ds, test_size="2")
    assert CountingStreets.loads == 0


def test_load_batch_refuses_float_indices_and_checks_frames():
    a = ArrayDataset(np.ones((3, 8, 9), np.float32))
    with pytest.raises(TypeError, match=r"indices must be non-negative integers, got \[0.7\]"):
        a.load_batch([0.7])
    with pytest.raises(ValueError, match="outside 0..2"):
        a.load_batch([3])
    assert a.load_batch([]).shape == (0, 8, 9)
    assert a.load_batch(np.array([2, 2])).shape == (2, 8, 9)  # repeats are fine when loading

    class Bad(DepthDataset):
        frame_shape = (4, 5)

        def __init__(self, frame):
            self.frame, self.groups, self.frame_ids = frame, np.asarray(["d"]), ["d/0"]

        def _load(self, index):
            return self.frame

    with pytest.raises(ValueError, match=r"frame 0 \(d/0\) contains negative depth"):
        Bad(np.full((4, 5), -1.0, np.float32)).load_batch([0])
    # A (1, W) frame would broadcast into the batch without a word.
    with pytest.raises(ValueError, match=r"frame 0 \(d/0\) has shape \(1, 5\), the dataset says \(4, 5\)"):
        Bad(np.ones((1, 5), np.float32)).load_batch([0])


def test_select_drives_refuses_an_empty_list_and_a_bare_string(ds):
    from inpaintenv.data import select_drives

    drive = sorted(set(ds.groups))[0]
    kept = select_drives(ds, [drive])
    assert set(kept.groups) == {drive}
    assert len(select_drives(ds, None, [])) == len(ds)  # excluding nothing is fine
    with pytest.raises(ValueError, match="drives is empty; pass None"):
        select_drives(ds, [])
    with pytest.raises(TypeError, match="list of drive names, got the string"):
        select_drives(ds, drive)
    with pytest.raises(TypeError, match="exclude must be a list"):
        select_drives(ds, None, drive)


def test_spaced_per_drive_weighs_drives_alike_first_and_last_kept():
    from inpaintenv.data import ArrayDataset, spaced_per_drive

    frames = np.zeros((13, 8, 8), np.float32)
    groups = ["a"] * 10 + ["b"] * 3
    ds = ArrayDataset(frames, groups=groups)
    picked = spaced_per_drive(ds, 4)
    assert list(picked.groups) == ["a"] * 4 + ["b"] * 3
    assert list(picked.indices) == [0, 3, 6, 9, 10, 11, 12]
    assert list(spaced_per_drive(ds, 0, drives=["b"]).indices) == [10, 11, 12]
    with pytest.raises(InvalidInputError, match="unknown drive 'c'"):
        spaced_per_drive(ds, 2, drives=["c"])
    with pytest.raises(InvalidInputError, match="per_drive must be an integer >= 0"):
        spaced_per_drive(ds, -1)
