"""What a benchmark method *is*, as a short string, so a resumed run never reuses rows
that another model made under the same display name.

* an estimator (has ``get_params``): ``Class(sorted params)`` without the parameters
  that only change speed (:data:`RUNTIME_PARAMS`), plus ``weights:<sha256>`` of its
  fitted network when it has one (``model_.state_dict()``), or, for an ensemble
  (``named_estimators_``), ``members:[name=weights:<sha256>, ...]`` of its fitted members.
  The class name, not its module: moving a class between modules keeps its identity;
* a saved checkpoint: ``checkpoint:<sha256>`` of the checkpoint's files, computed from
  disk without loading the model (:func:`files_identity`);
* any other callable: its qualified name, ``module.qualname`` (best effort: two lambdas
  in one module share a name).

A method (or :class:`~inpaintenv.benchmark.LazyMethod`) with a non-empty string attribute
``identity`` declares its own, e.g. a wrapper that only counts or times calls.
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path
from typing import Any

__all__ = ["RUNTIME_PARAMS", "files_identity", "method_identity"]

#: Parameters that change how fast a method runs or what it logs, never its output;
#: left out so that e.g. ``--n-jobs`` can change between a run and its resume.
RUNTIME_PARAMS = frozenset(
    {"n_jobs", "num_threads", "num_workers", "verbose", "checkpoint_dir", "checkpoint_every"}
)

# Default reprs carry a memory address that differs in every process.
_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


def _qualname(obj: Any) -> str:
    return f"{getattr(obj, '__module__', '?')}.{getattr(obj, '__qualname__', type(obj).__qualname__)}"


def _weights_sha256(model: Any) -> str:
    h = hashlib.sha256()
    for key, value in sorted(model.state_dict().items()):
        h.update(key.encode())
        # float(): numpy has no bfloat16; the values, not their storage type, matter here.
        h.update(value.detach().cpu().float().numpy().tobytes())
    return h.hexdigest()


def _fitted_weights(method: Any) -> str:
    """``weights:<sha256>`` of a fitted network, ``members:[...]`` of a fitted ensemble, else ``""``."""
    model = getattr(method, "model_", None)
    if callable(getattr(model, "state_dict", None)):
        return f"weights:{_weights_sha256(model)}"
    members = getattr(method, "named_estimators_", None)
    if isinstance(members, dict) and members:
        parts = [f"{name}={_fitted_weights(est) or '-'}" for name, est in members.items()]
        return f"members:[{', '.join(parts)}]"
    return ""


def files_identity(path: str | os.PathLike, kind: str = "checkpoint") -> str:
    """``"<kind>:<sha256>"`` of a file, or of every file under a folder (names and bytes).

    Parameters
    ----------
    path : path-like
        A weights file or a checkpoint folder (e.g. ``model/`` from ``inpaintenv train``).
    kind : str
        Prefix naming what the hash is of.

    Returns
    -------
    str
        Equal for byte-identical checkpoints wherever they are stored.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    """
    root = Path(path)
    if not root.exists():
        raise FileNotFoundError(f"checkpoint not found: {root}")
    files = [root] if root.is_file() else sorted(p for p in root.rglob("*") if p.is_file())
    h = hashlib.sha256()
    for file in files:
        if file != root:
            # The relative name too, so moving bytes between files changes the identity.
            h.update(file.relative_to(root).as_posix().encode() + b"\0")
        with open(file, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        h.update(b"\0")
    return f"{kind}:{h.hexdigest()}"


def method_identity(method: Any) -> str:
    """A string that changes whenever ``method`` would produce different predictions.

    Parameters
    ----------
    method : estimator or callable
        A built method (not a lazy factory; see :class:`~inpaintenv.benchmark.LazyMethod`,
        whose ``identity`` is used instead when set).

    Returns
    -------
    str
        See the module docstring for the forms.
    """
    identity = getattr(method, "identity", None)
    if isinstance(identity, str) and identity:
        return identity
    get_params = getattr(method, "get_params", None)
    if callable(get_params):
        params = {k: v for k, v in get_params(deep=False).items() if k not in RUNTIME_PARAMS}
        text = f"{type(method).__qualname__}({_ADDRESS.sub('', repr(sorted(params.items())))})"
        weights = _fitted_weights(method)
        return f"{text} {weights}" if weights else text
    if isinstance(getattr(method, "__qualname__", None), str):
        return _qualname(method)
    return _qualname(type(method))
