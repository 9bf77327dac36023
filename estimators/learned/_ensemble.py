"""MeanEnsembleInpainter: the per-pixel mean of several learned inpainters.

Two models of different families err in different places: on the leave-one-day-out folds
the mean of the context blend (kitti-context-v3's recipe) and the per-pixel blend
(kitti-rect-v4's) beat both (docs/reference/selection.md). This estimator holds such
members, fits each on the same frames, and predicts their per-pixel mean. Members that
read the same candidate fills (the blend family: same ``candidates`` and ``endpoints``)
share them: the features, most of a blend's cost, are computed once per frame.

Like scikit-learn's :class:`~sklearn.ensemble.VotingRegressor`, the members are given as
``(name, estimator)`` pairs, and their parameters are reachable as ``name__param`` by
``get_params`` / ``set_params`` (so ``GridSearchCV`` can search them).

>>> from estimators.learned import MeanEnsembleInpainter          # doctest: +SKIP
>>> from estimators.learned import BlendInpainter
>>> from estimators.learned import ContextBlendInpainter
>>> est = MeanEnsembleInpainter([("context", ContextBlendInpainter()),
...                              ("blend", BlendInpainter(tta=False))]).fit(frames)
>>> est.predict(depth_with_nan_holes)                                        # metres
"""

from __future__ import annotations

import re
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
from sklearn.base import clone

from inpaintenv.data.base import DepthDataset
from inpaintenv.report.provenance import environment_info
from inpaintenv.exceptions import InvalidInputError

from ..base import BaseInpainter, check_n_jobs, check_random_state
from . import _checkpoint as ckpt
from ._blend import BlendInpainter
from ._context_blend import ContextBlendInpainter
from ._neural import AutoencoderInpainter, UNetInpainter
from ._prior import PriorUNetInpainter
from ._scan_blend import ScanBlendInpainter
from .._constraints import Bool, Check, ConstrainedParams, InstanceOf, Integer
from ._limits import MAX_THREADS
from ._output import bound_output
from ._persistence import PersistenceMixin
from ._training import torch_threads

__all__ = ["MeanEnsembleInpainter"]

#: Parameters that, when set on the ensemble (not None), are passed to every member that has them.
_SHARED_PARAMS = ("random_state", "num_threads", "n_jobs", "verbose")
#: The classes a member may be (besides an ensemble), by the name its nested config records.
_MEMBER_CLASSES: dict[str, type] = {klass.__name__: klass for klass in (
    UNetInpainter, AutoencoderInpainter, PriorUNetInpainter, BlendInpainter, ContextBlendInpainter,
    ScanBlendInpainter)}
#: Member names: they prefix the members' parameters (``name__param``) and weights (``name.key``).
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9]*(_[A-Za-z0-9]+)*")


class MeanEnsembleInpainter(ConstrainedParams, PersistenceMixin, BaseInpainter):
    """Per-pixel mean of the predictions of several learned inpainters.

    Parameters
    ----------
    estimators : list of (str, estimator)
        The members, each a name (letters, digits and single underscores, starting with a
        letter; unique) and an unfitted inpainter. ``fit`` fits a clone of each.
    random_state, num_threads, n_jobs : optional
        When not None, given to every member that has the parameter (its own value
        otherwise): one seed, torch thread count or feature-job count for the whole fit.
    verbose : bool, int or None, default None
        When not None, given to every member (progress of ``fit``).
    predict_threads : int or None, default 1
        torch threads while predicting (None: leave torch's setting).
    keep_observed : bool, default True
        Return measured input pixels unchanged.
    weights : sequence of float or None, default None
        One non-negative weight per member, in the order of ``estimators`` (not all zero):
        the prediction is the weighted mean, as in scikit-learn's ``VotingRegressor``.
        None: every member weighs the same.

    Attributes
    ----------
    estimators_ : list of estimators
        The fitted members, in the order of ``estimators``.
    named_estimators_ : dict
        The fitted members by name.
    shares_features_ : bool
        Whether ``predict`` computes the candidate features once for all members (every
        member is of the blend family and reads the same candidates and endpoints).
    fit_seconds_ : float
        Wall-clock time of ``fit``; ``member_fit_seconds_`` per member.
    history_ : dict
        ``epoch_loss_by_member``: each member's training loss per epoch, by name.

    Notes
    -----
    Without ``weights`` the mean is unweighted: a member that is itself an ensemble
    (``n_members=2``) counts once. Every member must predict the frames it is given; ``predict`` checks each one's
    parameters as its own ``predict`` would.
    """

    def __init__(
        self,
        estimators: list[tuple[str, Any]],
        *,
        random_state: Any = None,
        num_threads: int | None = None,
        n_jobs: int | None = None,
        verbose: bool | None = None,
        predict_threads: int | None = 1,
        keep_observed: bool = True,
        weights: Sequence[float] | None = None,
    ):
        self.estimators = estimators
        self.random_state = random_state
        self.num_threads = num_threads
        self.n_jobs = n_jobs
        self.verbose = verbose
        self.predict_threads = predict_threads
        self.keep_observed = keep_observed
        self.weights = weights

    # -- parameters (scikit-learn's nested name__param, as in VotingRegressor) ----------------
    def _check_members(self) -> list[tuple[str, Any]]:
        members = self.estimators
        if isinstance(members, (str, bytes)) or not isinstance(members, (list, tuple)) or len(members) < 2:
            raise InvalidInputError(f"estimators must be a list of at least two (name, estimator) pairs, got {members!r}")
        names = []
        for item in members:
            if not (isinstance(item, (list, tuple)) and len(item) == 2 and isinstance(item[0], str)):
                raise InvalidInputError(f"each member must be a (name, estimator) pair, got {item!r}")
            name, est = item
            if not _NAME.fullmatch(name):
                raise InvalidInputError(f"member name {name!r}: use letters, digits and single underscores, "
                                 "starting with a letter (it prefixes the member's parameters as name__param)")
            if not (hasattr(est, "fit") and hasattr(est, "predict")):
                raise InvalidInputError(f"member {name!r} is a {type(est).__name__}, not an inpainter with fit and predict")
            names.append(name)
        if len(set(names)) != len(names):
            raise InvalidInputError(f"member names must be unique, got {names}")
        if set(names) & set(self._own_params()):
            clash = sorted(set(names) & set(self._own_params()))
            raise InvalidInputError(f"member names must differ from the ensemble's parameters: {clash}")
        return [(n, e) for n, e in members]

    def _member_map(self) -> dict[str, Any]:
        """The ``(name, estimator)`` pairs of ``estimators`` by name, without validation."""
        members = self.estimators if isinstance(self.estimators, (list, tuple)) else []
        return {item[0]: item[1] for item in members
                if isinstance(item, (list, tuple)) and len(item) == 2 and isinstance(item[0], str)}

    #: The ensemble's own parameters; the members' are checked by the members (with the
    #: shared ones applied), the pairs and weights by :meth:`_check_param_relations`.
    _parameter_constraints: dict[str, list[Any]] = {
        "random_state": [Check(check_random_state)],
        "num_threads": [Integer(1, limit=MAX_THREADS), None],
        "verbose": [Bool(), Integer(0), None],
        "predict_threads": [Integer(1, limit=MAX_THREADS), None],
        "keep_observed": [Bool()],
        # The members and their weights are checked one by one in _check_param_relations.
        "estimators": [InstanceOf((list, tuple), "a non-empty list of (name, estimator) pairs")],
        "weights": [InstanceOf((list, tuple, np.ndarray), "a list of numbers, one per member"), None],
        "n_jobs": [Check(check_n_jobs), None],
    }

    def _check_param_relations(self) -> None:
        """Check the members, the weights and, with the ensemble's shared parameters applied, each member's own."""
        members = self._check_members()
        self._member_weights(len(members))
        for _, est in members:
            check = getattr(est, "_check_params", None)
            if callable(check):
                check_member = self._with_shared(clone(est))
                check_member._check_params()

    def _member_weights(self, n_members: int) -> np.ndarray | None:
        """``weights`` as a checked float array of one weight per member (None: equal weights)."""
        if self.weights is None:
            return None
        try:
            w = np.asarray(self.weights, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidInputError(f"weights must be numbers, one per member, got {self.weights!r}") from None
        if w.shape != (n_members,):
            raise InvalidInputError(f"weights must hold one number per member ({n_members}), got {self.weights!r}")
        if not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
            raise InvalidInputError(f"weights must be finite, non-negative and not all zero, got {self.weights!r}")
        return w

    def _with_shared(self, member: Any) -> Any:
        """``member`` with the ensemble's shared parameters that are set and that it has."""
        accepted = member.get_params(deep=False)
        member.set_params(**{k: getattr(self, k) for k in _SHARED_PARAMS
                             if getattr(self, k) is not None and k in accepted})
        return member

    def _check_size(self) -> None:
        """Nothing to check: each member checked its own size when it was built."""

    @classmethod
    def _own_params(cls) -> list[str]:
        return super()._get_param_names()

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The ensemble's parameters; with ``deep``, every member as ``name`` and its parameters as ``name__param``."""
        out = super().get_params(deep=False)
        if not deep:
            return out
        for name, est in self._member_map().items():
            out[name] = est
            if hasattr(est, "get_params"):
                out.update({f"{name}__{k}": v for k, v in est.get_params(deep=True).items()})
        return out

    def set_params(self, **params: Any) -> MeanEnsembleInpainter:
        """Set the ensemble's parameters, a member (``name=estimator``) or a member's parameter (``name__param``)."""
        # No validation here (scikit-learn's contract): fit checks the members.
        if "estimators" in params:
            self.estimators = params.pop("estimators")
        members = self._member_map()
        own = set(self._own_params())
        nested: dict[str, dict[str, Any]] = {}
        replaced = False
        for key, value in params.items():
            name, sep, sub = key.partition("__")
            if key in own:
                setattr(self, key, value)
            elif name in members and not sep:
                members[name] = value
                replaced = True
            elif name in members:
                nested.setdefault(name, {})[sub] = value
            else:
                raise InvalidInputError(f"invalid parameter {key!r} for {type(self).__name__}: its own are "
                                 f"{sorted(own)}, its members {sorted(members)} (name__param)")
        if replaced:  # otherwise `estimators` stays the very object given (scikit-learn's contract)
            self.estimators = list(members.items())
        for name, sub in nested.items():
            members[name].set_params(**sub)
        # fitted members follow prediction-time changes too (e.g. blend__tta=False after load)
        for name, sub in nested.items():
            fitted = getattr(self, "named_estimators_", {}).get(name)
            if fitted is not None and fitted is not members[name]:
                fitted.set_params(**sub)
        return self

    # -- fitting ---------------------------------------------------------------------------
    def _fit(self, dataset: DepthDataset) -> None:
        self._check_params()
        members = self._check_members()
        start = time.perf_counter()
        fitted, seconds = [], []
        for name, est in members:
            member = self._with_shared(clone(est))
            if self.verbose:
                print(f"member {name} ({type(member).__name__})", flush=True)
            t0 = time.perf_counter()
            member.fit(dataset)
            seconds.append(time.perf_counter() - t0)
            fitted.append(member)
        self._set_fitted(members, fitted)
        self.member_fit_seconds_ = seconds
        self.fit_seconds_ = time.perf_counter() - start
        self.fit_environment_ = environment_info(torch_details=True)

    def _set_fitted(self, members: list[tuple[str, Any]], fitted: list[Any]) -> None:
        self.estimators_ = fitted
        self.named_estimators_ = {name: est for (name, _), est in zip(members, fitted)}
        self.shares_features_ = _share_features(fitted)
        self.history_ = {"epoch_loss_by_member": {name: list((getattr(est, "history_", None) or {}).get("epoch_loss", []))
                                               for name, est in self.named_estimators_.items()}}

    # -- prediction ------------------------------------------------------------------------
    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        members = self.estimators_
        weights = self._member_weights(len(members))
        if not self.shares_features_:
            return bound_output(np.average([np.asarray(m.predict(X), np.float32) for m in members], axis=0,
                                          weights=weights).astype(np.float32), X)
        for m in members:
            m._check_params_once()
            m._check_model_params()
        out = np.empty(X.shape, np.float32)
        with torch_threads(self.predict_threads), torch.inference_mode():
            for i, frame in enumerate(X):
                feats = members[0]._features(frame)
                out[i] = np.average([m._predict_features(frame, feats) for m in members], axis=0, weights=weights)
        return bound_output(out, X)

    # -- persistence (the hooks of PersistenceMixin) ------------------------------------------
    def _config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        """Every member's full config nested under its name; every member's weights as ``name.key``."""
        members = self._check_members()
        configs, weights = [], {}
        for (name, _), est in zip(members, self.estimators_):
            if not callable(getattr(est, "to_config", None)):
                raise InvalidInputError(f"member {name!r} ({type(est).__name__}) cannot be saved")
            member_config, member_weights = est.to_config()
            configs.append({"name": name, "config": member_config})
            weights.update({f"{name}.{k}": v for k, v in member_weights.items()})
        params = {k: v for k, v in self.get_params(deep=False).items() if k != "estimators"}
        if not isinstance(params["random_state"], (int, type(None))):
            params["random_state"] = None  # a RandomState or Generator is not JSON; members record their seeds
        if params["weights"] is not None:
            params["weights"] = [float(w) for w in self._member_weights(len(members))]
        config = {"params": params, "members": configs,
                  "fit": {"fit_seconds": float(getattr(self, "fit_seconds_", float("nan"))),
                          "member_fit_seconds": list(getattr(self, "member_fit_seconds_", []))}}
        return config, weights

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], path: Any) -> MeanEnsembleInpainter:
        """Each member built in memory from its nested config and its share of the weights (no file
        is written, whatever the config holds)."""
        entries = _member_entries(config, path)
        names = [name for name, _ in entries]
        stray = [k for k in weights if k.partition(".")[0] not in names]
        if stray:
            raise ckpt.CheckpointError(f"{path}: weights of no member: {stray[:3]}")
        fitted = []
        for name, member_config in entries:
            where = f"{path} (member {name!r})"
            own = {k[len(name) + 1:]: v for k, v in weights.items() if k.startswith(f"{name}.")}
            klass = ckpt.recorded_class(member_config, where, {**_MEMBER_CLASSES, cls.__name__: cls})
            fitted.append(klass.from_config(member_config, own, where))
        params = {**ckpt.config_value(config, "params", dict, path),
                  "estimators": [(n, clone(m)) for n, m in zip(names, fitted)]}
        est = ckpt.build_checked(cls, params, path)
        est._set_fitted(est._check_members(), fitted)
        fit = ckpt.config_value(config, "fit", dict, path, default={})
        est.fit_seconds_ = ckpt.config_value(fit, "fit_seconds", float, path, default=float("nan"))
        est.member_fit_seconds_ = list(ckpt.config_value(fit, "member_fit_seconds", list, path, default=[]))
        return est

    @classmethod
    def from_fitted(cls, members: list[tuple[str, Any]], **params: Any) -> MeanEnsembleInpainter:
        """An ensemble of members fitted elsewhere (e.g. two saved fold models), ready to predict or save.

        ``training_drives_`` is the union of the members' (None if one does not record them).
        """
        est = cls([(n, clone(m)) for n, m in members], **params)
        checked = est._check_members()
        not_fitted = [n for n, m in members if not getattr(m, "is_fitted_", False)]
        if not_fitted:
            raise InvalidInputError(f"members not fitted: {not_fitted}")
        est._set_fitted(checked, [m for _, m in members])
        drives = [getattr(m, "training_drives_", None) for _, m in members]
        est.training_drives_ = None if any(d is None for d in drives) else sorted(set().union(*drives))
        est.fit_environment_ = None
        est.is_fitted_ = True
        return est


def _member_entries(config: dict[str, Any], path: Any) -> list[tuple[str, dict[str, Any]]]:
    """The ``(name, config)`` of every member a checkpoint's config lists, each name checked
    as an identifier (it prefixes the member's weights and parameters; never a path)."""
    entries = ckpt.config_value(config, "members", list, path)
    if len(entries) < 2:
        raise ckpt.CheckpointError(f"{path}: config.json 'members' must list at least two members, got {len(entries)}")
    out: list[tuple[str, dict[str, Any]]] = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, dict):
            raise ckpt.CheckpointError(f"{path}: config.json 'members'[{i}] must be a JSON object "
                                       f"with 'name' and 'config', got {entry!r:.60}")
        name = entry.get("name")
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise ckpt.CheckpointError(f"{path}: config.json 'members'[{i}] has name {name!r:.60}; a member name "
                                       "is letters, digits and single underscores, starting with a letter")
        if name in (n for n, _ in out):
            raise ckpt.CheckpointError(f"{path}: config.json names member {name!r} twice")
        out.append((name, ckpt.config_value(entry, "config", dict, f"{path} (member {name!r})")))
    return out


def _share_features(members: list[Any]) -> bool:
    """Whether every member is a blend estimator reading the same candidate features."""
    if not all(hasattr(m, "_features") and hasattr(m, "_predict_features") for m in members):
        return False
    return len({(tuple(m.candidates), bool(m.endpoints)) for m in members}) == 1


# estimators.learned.load finds classes by the name a checkpoint records.
