"""``pretrained`` at every density: KITTI's official val_selection scans thinned to 32, 16 and 8 beams
(every 2nd / 4th / 8th laser ring kept) are filled no worse than ``harmonic``, as the 64-beam scan is,
and given the sparse route's shipped interval; the sparse release is no worse than ``harmonic`` there."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.data.calibration import Calibration, read_calibration
from inpaintenv.data.inputs import method_input
from inpaintenv.data.thinning import thin_scan_by_rings
from release_checks import check_shipped_interval

#: Every k-th laser ring kept of KITTI's 64: 64, 32, 16 and 8 beams.
KEEP_EVERY = (1, 2, 4, 8)
#: val_selection's frames are bottom-centre 352 x 1216 crops of 2011_09_26's 1242 x 375 images.
RAW_SIZE, CROP = (1242, 375), (352, 1216)


def _cropped(calibration: Calibration) -> Calibration:
    """``calibration`` shifted to the bottom-centre crop the val_selection frames are."""
    (width, height), (ch, cw) = RAW_SIZE, CROP
    shift = np.array([[1.0, 0.0, -((width - cw) // 2)], [0.0, 1.0, -(height - ch)], [0.0, 0.0, 1.0]])
    return Calibration(shift @ calibration.matrix, (cw, ch), calibration.kind, calibration.source, calibration.camera)


@pytest.fixture(scope="module")
def thinned_val_selection(kitti_root):
    """Per kept ring step: the method inputs of val_selection's scans and the ground-truth pixels scored
    (the ones the thinned scan does not measure), with the ground truth."""
    from inpaintenv.data import KittiDepth

    if not (kitti_root / "depth_selection").is_dir() or not (kitti_root / "calib" / "2011_09_26").is_dir():
        pytest.skip("the KITTI slice has no depth_selection/ or no 2011_09_26 calibration")
    frames = KittiDepth(kitti_root, split="val_selection", camera="both", input="scan")
    scans, gt = frames.load_pairs(range(len(frames)))
    cameras = [int(fid.split("/")[1][-1]) for fid in frames.frame_ids]
    calib = {c: _cropped(read_calibration(kitti_root / "calib" / "2011_09_26", size=RAW_SIZE, camera=c))
             for c in set(cameras)}
    out = {}
    for k in KEEP_EVERY:
        thin = np.stack([s if k == 1 else thin_scan_by_rings(s, calib[c], k) for s, c in zip(scans, cameras)])
        x = method_input(thin, np.zeros(thin.shape, bool), "scan")
        out[k] = (x, gt, (gt > 0) & np.isnan(x))
    return out


def _mean_rmse(pred, gt, scored) -> float:
    """The mean over frames of each frame's RMSE on its scored pixels."""
    return float(np.mean([np.sqrt(np.mean((p[m] - g[m]) ** 2)) for p, g, m in zip(pred, gt, scored)]))


@pytest.fixture(scope="module")
def filled(thinned_val_selection):
    """Per kept ring step: the mean RMSE over frames of ``pretrained`` and of ``harmonic``, and pretrained's routes."""
    pytest.importorskip("torch")
    from inpaintenv.methods.registry import make_method

    ours, harmonic = make_method("pretrained"), make_method("harmonic")
    scores = {}
    for k, (x, gt, scored) in thinned_val_selection.items():
        rmse = [_mean_rmse(method.predict(x), gt, scored) for method in (ours, harmonic)]
        scores[k] = (*rmse, list(ours.routed_to_))
    return scores


@pytest.mark.kitti
def test_thinned_scans_keep_about_their_share_of_the_points(thinned_val_selection):
    full = np.isfinite(thinned_val_selection[1][0]).sum()
    for k in KEEP_EVERY[1:]:
        share = np.isfinite(thinned_val_selection[k][0]).sum() / full
        assert 0.4 / k < share < 1.6 / k, (k, share)


@pytest.mark.kitti
@pytest.mark.parametrize("keep_every", KEEP_EVERY)
def test_pretrained_is_no_worse_than_harmonic_at_64_32_16_and_8_beams(filled, keep_every):
    ours, harmonic, _ = filled[keep_every]
    assert ours <= harmonic + 1e-6, (keep_every, ours, harmonic)


@pytest.mark.kitti
def test_the_sparse_release_is_no_worse_than_harmonic_at_32_16_and_8_beams(thinned_val_selection):
    """kitti-sparse-v1 never saw val_selection (nor chose its shrink on it): below harmonic at each density."""
    pytest.importorskip("torch")
    from inpaintenv.methods.registry import make_method

    release, harmonic = make_method("kitti-sparse-v1"), make_method("harmonic")
    for k in KEEP_EVERY[1:]:
        x, gt, scored = thinned_val_selection[k]
        ours, theirs = (_mean_rmse(m.predict(x), gt, scored) for m in (release, harmonic))
        assert ours < theirs, (k, ours, theirs)


@pytest.mark.kitti
def test_a_64_beam_scan_takes_the_scan_route_and_a_thinned_one_the_sparse_route(filled):
    from inpaintenv.methods.learned import SCAN_DEFAULT, SPARSE_DEFAULT

    assert set(filled[1][2]) == {SCAN_DEFAULT}
    for k in KEEP_EVERY[1:]:
        assert set(filled[k][2]) == {SPARSE_DEFAULT}, k


@pytest.mark.kitti
def test_pretrained_gives_a_16_beam_scan_the_sparse_route_s_shipped_interval(thinned_val_selection):
    """A few val_selection scans thinned to 16 beams: pretrained's predict_interval and
    predict(X, return_std=True) answer from the sparse route's shipped calibration, around its fill."""
    from inpaintenv.methods.learned import SPARSE_DEFAULT
    from inpaintenv.methods.registry import make_method

    x = thinned_val_selection[4][0][:2]
    routed = make_method("pretrained")
    pred = routed.predict(x)
    assert routed.routed_to_ == [SPARSE_DEFAULT] * len(x)
    check_shipped_interval(routed, x, pred)
    assert "scan-rings16-v1" in routed.interval_method("sparse").calibration_["input_kind"]
