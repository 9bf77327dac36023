"""``verbose`` of a learned fit, as scikit-learn's: > 0 shows progress (a bar on a terminal, one line
per epoch in a log), 0 / False nothing; a negative one is refused."""

from __future__ import annotations

import re

import pytest

pytest.importorskip("torch")

from estimators.learned import UNetInpainter  # noqa: E402
from inpaintenv.data import SyntheticStreets  # noqa: E402
from inpaintenv.exceptions import InpaintenvError  # noqa: E402


@pytest.fixture(scope="module")
def data():
    return SyntheticStreets(n=8, frame_shape=(32, 96))


def _fit(data, verbose):
    return UNetInpainter(width=4, depth=2, epochs=2, batch_size=4, random_state=0, verbose=verbose).fit(data)


def test_verbose_one_gives_a_line_per_epoch_in_a_log(data, capsys):
    _fit(data, 1)  # capsys: stderr is not a terminal, as in a log or a joblib worker's pipe
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(lines) == 2, lines
    assert re.match(r"UNetInpainter: epoch 1/2, step 2/4, loss \d+\.\d{4}, ", lines[0])
    assert lines[1].startswith("UNetInpainter: epoch 2/2, step 4/4, ") and lines[1].endswith("left")
    assert "\r" not in capsys.readouterr().err


def test_verbose_zero_is_silent_and_a_negative_one_refused(data, capsys):
    _fit(data, 0)
    assert capsys.readouterr().err == ""
    with pytest.raises(InpaintenvError, match="verbose"):
        UNetInpainter(verbose=-1).fit(data)
