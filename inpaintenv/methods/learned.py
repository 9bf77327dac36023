"""The shipped learned releases, the default ones, and the extra they need: a data module.

Torch-free and free of ``estimators`` and of the registry, so that both the registry
(which names the releases) and :mod:`estimators.learned` (which loads them) read the one
definition of each: the folder of the releases, :data:`DEFAULT_RELEASE`,
:data:`SCAN_DEFAULT`, :func:`shipped`, and the one-line error about the ``[learned]``
extra (:func:`require_learned`).

>>> from inpaintenv.methods.learned import DEFAULT_RELEASE, shipped
>>> DEFAULT_RELEASE in shipped()
True
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

from ..exceptions import MissingDependencyError
from ..files import read_json

__all__ = [
    "DEFAULT_RELEASE",
    "LEARNED_DEPENDENCIES",
    "LEARNED_INSTALL",
    "RELEASE_DIR",
    "SCAN_DEFAULT",
    "POINTS_DEFAULT",
    "SPARSE_DEFAULT",
    "MissingExtraError",
    "learned_missing",
    "missing_extra_error",
    "require_learned",
    "shipped",
]

#: Folder of the shipped releases, ``NAME.safetensors`` + ``NAME.json`` (a checkpoint's two
#: files under flat names): ``estimators`` lies beside ``inpaintenv`` in the repository and in
#: an installed wheel alike, so no import is needed to find it.
RELEASE_DIR = Path(__file__).resolve().parents[2] / "estimators" / "pretrained"

#: The release ``-m pretrained`` fills a map with: the default learned method (docs/model_card.md).
DEFAULT_RELEASE = "kitti-ensemble-v1"

#: What ``pretrained`` fills a single LiDAR scan with: the scan release, the classical mean
#: ``harmonic-ipbasic`` near the scan's measurements and a learned blend far from them (in a hole);
#: on both official sets with a scan it is no worse than every classical fill on densify and
#: better in rect-v1's holes (docs/model_cards/kitti-scan-v1.md).
SCAN_DEFAULT = "kitti-scan-v1"

#: What ``pretrained`` fills a LiDAR scan of fewer lines than a 64-beam one with (32, 16, 8 beams):
#: the sparse release, ``harmonic`` plus half a learned per-pixel correction, below the strongest
#: classical fill at every one of those densities on every recording day left out
#: (docs/model_cards/kitti-sparse-v1.md); there the scan release's blend is worse than the classical fills.
SPARSE_DEFAULT = "kitti-sparse-v1"

#: What ``pretrained`` fills a scan of points scattered far apart along its lines with (a tenth of a
#: scan's points kept at random): the classical mean ``harmonic-ipbasic``, the strongest classical
#: fill there on every recording day, where the scan release's learned blend is 1.01-1.02x worse
#: (docs/model_cards/kitti-scan-v1.md).
POINTS_DEFAULT = "harmonic-ipbasic"

#: The modules the ``[learned]`` extra brings (import names).
LEARNED_DEPENDENCIES: tuple[str, ...] = ("torch", "safetensors")
#: What to install for the learned methods; the CPU build first keeps pip from pulling
#: several GB of CUDA packages on a machine without a GPU.
LEARNED_INSTALL = (
    'pip install "inpaintenv[learned]" (on a CPU-only Linux machine, first '
    "pip install torch --index-url https://download.pytorch.org/whl/cpu)"
)


def shipped(directory: Path = RELEASE_DIR) -> dict[str, str]:
    """Every complete release in ``directory`` (weights and JSON present) and the class its JSON records.

    A release whose JSON cannot be read is listed with the class ``"?"``: loading it names its problem.
    """
    if not directory.is_dir():
        return {}
    out = {}
    for path in sorted(directory.glob("*.json")):
        if path.with_suffix(".safetensors").is_file():
            try:
                doc = read_json(path, "shipped release")  # regular file, bounded size and nesting
            except (OSError, ValueError):
                doc = None
            out[path.stem] = str(doc.get("class")) if isinstance(doc, dict) else "?"
    return out


class MissingExtraError(MissingDependencyError):
    """A learned method was named, but the ``[learned]`` extra (torch, safetensors) is not installed.

    An ``ImportError`` (and an :class:`~inpaintenv.exceptions.InpaintenvError`: the CLI prints it as one line).
    """


def learned_missing() -> list[str]:
    """The modules of the ``[learned]`` extra that cannot be found here (empty when installed).

    Found without importing them (torch takes seconds to import).
    """
    missing = []
    for module in LEARNED_DEPENDENCIES:
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            missing.append(module)
    return missing


def missing_extra_error(what: str, missing: list[str]) -> MissingExtraError:
    """The one-line error for ``what`` (e.g. ``"method 'pretrained' (a learned model)"``), which
    needs the ``missing`` modules of the ``[learned]`` extra."""
    return MissingExtraError(f"{what} needs {' and '.join(missing)}, not installed here: {LEARNED_INSTALL}")


def require_learned(what: str) -> None:
    """Raise :class:`MissingExtraError` about ``what`` unless the ``[learned]`` extra is installed.

    Raises
    ------
    MissingExtraError
        If torch or safetensors cannot be found.
    """
    if missing := learned_missing():
        raise missing_extra_error(what, missing)
