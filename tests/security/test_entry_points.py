"""Every entry point of the package against the same hostile files.

:data:`CASES` is the table: each entry point (every CLI subcommand, ``load``,
``load_release``, ``fill``/``fill_depth``, ``ConformalIntervalInpainter.load``, the Gymnasium
env, ``evaluate`` over a KITTI folder) with each hostile file it can be handed where it
reads such a file: a FIFO, a symbolic link out of the folder the command owns, a name
that is not UTF-8, a PNG bomb header, 200 kB of nested JSON, NaN/negative/huge numbers in
JSON fields. Each case must end within :data:`TIME_LIMIT` seconds with ONE clear error that
names the problem (the CLI: exit status 1 or 2, one ``inpaintenv <command>: ...`` line on
stderr, no traceback or warning; Python: an ``InpaintenvError`` or an ``OSError``) -- or,
where the file is legitimate (a name that is not UTF-8, an output replaced rather than
written through), with success -- and nothing written outside the case's folder (a victim
file's and a victim folder's bytes are checked). The commands run in-process, in the
case's folder, so a default output folder lands there too.

A new entry point that is not in the table fails :func:`test_every_entry_point_is_in_the_table`.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import stat
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hostile_files import (
    BOMB, INTERVALS, MASK_BOMB, NESTED, NOT_UTF8, NPY_BOMB, ODOMETRY, VICTIM, Place, png, settable,
)
from hostile_rows import HOSTILE_ROWS, tamper_rows

from inpaintenv.cli.main import build_parser, main
from inpaintenv.data import write_depth_png
from inpaintenv.exceptions import InpaintenvError

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs and symbolic links are POSIX")

#: Seconds a case may take: a hang fails instead of blocking CI.
TIME_LIMIT = 20
#: Fast flags for the synthetic source.
TINY = ["--synthetic", "--n-frames", "2", "--frame-shape", "32", "64", "-q"]
#: A smoke training of three steps on it (one step an epoch).
TRAIN = [*TINY, "--max-steps", "3"]


# -- the runs that make folders to tamper with (each case copies what it needs) --------------

@pytest.fixture(scope="module")
def benchmark_run(tmp_path_factory) -> Path:
    """A finished two-frame benchmark run folder."""
    out = tmp_path_factory.mktemp("bench") / "run"
    assert main(["benchmark", *TINY, "--holdout", "0", "-m", "scanline", "--figure-frames", "0", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    """A two-frame export (``kit/``, ``kit.key.json``) and its predictions (``pred/``)."""
    from inpaintenv.submission import export

    base = tmp_path_factory.mktemp("export")
    manifest = export(base / "kit", None, n_frames=2, progress=False)
    for item in manifest.items:
        write_depth_png(base / "pred" / item.input,
                        np.where(manifest.read_hole(item), 10.0, manifest.read_input(item)))
    return base


@pytest.fixture(scope="module")
def train_run(tmp_path_factory) -> Path:
    """A smoke training stopped by its time budget after step 2 of 3: a run the next ``train`` resumes."""
    from estimators.learned import _budget

    out = tmp_path_factory.mktemp("train") / "t"
    looks = iter(range(0, 10_000, 60))  # one minute further on at every look
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_budget, "clock", lambda: float(next(looks)))
        assert main(["train", "--preset", "smoke", *TRAIN, "--max-minutes", "1.5", "--out", str(out)]) == 0
    return out


# -- the table ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Case:
    """One hostile file through one entry point.

    ``call(place, fixtures)`` builds the files under ``place.work`` and returns either a CLI
    argv (a list) or a Python callable. ``ok`` says whether success is also right (the file
    is legitimate, or an output that is replaced rather than written through).
    """

    entry: str
    hostile: str
    call: Callable[[Place, dict], list[str] | Callable[[], Any]]
    ok: bool = False
    says: str = ""

    @property
    def id(self) -> str:
        return f"{self.entry}:{self.hostile}"

    @property
    def names(self) -> str:
        """What the error must name (a regular expression): the problem, not a consequence of it."""
        if self.says:
            return self.says
        for kind, pattern in SAYS.items():
            if kind in self.hostile:
                return pattern
        return ""


#: ``says`` of a case that must succeed (``ok=True``): no error line can match it.
SUCCESS_ONLY = "(?!)"

#: What the error names, by the kind of hostile file (a FIFO is not "not found"; a bomb's size is shown).
SAYS = {"fifo": "FIFO|not a regular file", "bomb": "20000|60000", "nested": "nested", "link-out": "symbolic link",
        "nan": "NaN|nan", "not-utf8": "UTF-8|utf-8|encod"}


def _cli_kitti(command: list[str], bad: str) -> Callable[[Place, dict], list[str]]:
    return lambda p, f: [*command, "--kitti-root", str(p.kitti(bad)), "-q"]


def _run_dir(p: Place, f: dict, tamper: Callable[[Path], Any]) -> list[str]:
    out = p.work / "run"
    shutil.copytree(f["benchmark_run"], out, symlinks=True)
    tamper(out)
    return ["benchmark", *TINY, "--holdout", "0", "-m", "scanline", "--figure-frames", "0", "--out", str(out)]


def _report_dir(p: Place, f: dict, tamper: Callable[[Path], Any]) -> list[str]:
    out = p.work / "run"
    shutil.copytree(f["benchmark_run"], out, symlinks=True)
    tamper(out)
    return ["report", str(out), "-q"]


def _train_resume(p: Place, f: dict, tamper: Callable[[Path], Any]) -> list[str]:
    """``train`` resuming a copy of the stopped smoke run whose last checkpoint ``tamper`` edited."""
    out = p.work / "t"
    shutil.copytree(f["train_run"], out)
    run = next((out / "checkpoints").iterdir())
    tamper(run / json.loads((run / "state.json").read_text())["last"])
    return ["train", "--preset", "smoke", *TRAIN, "--out", str(out)]


def _state(edit: Callable[[dict], Any], checksum: bool = False) -> Callable[[Path], None]:
    """Edit a checkpoint's ``training.json`` (``checksum``: and record the edit's SHA-256 in its ``config.json``)."""
    def tamper(ckpt: Path) -> None:
        path = ckpt / "training.json"
        state = json.loads(path.read_text())
        edit(state)
        path.write_text(json.dumps(state))
        if checksum:
            config = json.loads((ckpt / "config.json").read_text())
            config["training_sha256"] = hashlib.sha256(path.read_bytes()).hexdigest()
            (ckpt / "config.json").write_text(json.dumps(config))
    return tamper


def _training_states() -> list[Case]:
    """``train`` resuming an edited training state: the checksum refuses it, and so does the
    state's consistency when the checksum is recomputed; a state of the wrong form is one line."""
    lr = lambda s: s["optimizer"]["param_groups"][0].update(lr=50.0)  # noqa: E731
    edits: list[tuple[str, Callable[[dict], Any], str]] = [
        ("step", lambda s: s.update(step=s["step"] + 98, batch=s["batch"] + 98), "disagrees with its checkpoint folder"),
        ("lr-50", lr, "lr=50.0 disagrees"),
        ("finished", lambda s: s.update(finished=True), "says finished at step 2"),
        ("fake-history", lambda s: s["history"].update(step_loss=[9.0] * 5), "'step_loss' has 5 entries"),
        ("step-string", lambda s: s.update(step="2"), "'step' must be an integer"),
        ("history-null", lambda s: s.update(history=None), "'history' must be an object"),
        ("no-optimizer", lambda s: s.pop("optimizer"), "has no 'optimizer'"),
        ("extra-key", lambda s: s.update(extra=1), "'extra' is not a key of a training state"),
        ("negative-step", lambda s: s.update(step=-1), "never negative"),
    ]
    cases = [Case("cli:train", f"state-{name}", lambda p, f, e=edit: _train_resume(p, f, _state(e)),
                  says=r"training\.json does not match the checksum") for name, edit, _ in edits[:4]]
    cases += [Case("cli:train", f"state-{name}-checksummed", lambda p, f, e=edit: _train_resume(
        p, f, _state(e, checksum=True)), says=re.escape(says)) for name, edit, says in edits]
    cases.append(Case("cli:train", "state-unchecksummed", lambda p, f: _train_resume(p, f, lambda c: (
        c / "config.json").write_text(json.dumps({k: v for k, v in json.loads((c / "config.json").read_text()).items()
                                                  if k != "training_sha256"}))),
        says="records no SHA-256 of training.json"))
    cases.append(Case("cli:train", "state-fifo", lambda p, f: _train_resume(
        p, f, lambda c: _replace(c / "training.json", p.fifo))))
    # The run folder inside --out/checkpoints, or its last checkpoint, a link to a folder outside.
    cases.append(Case("cli:train", "run-folder-link-out", lambda p, f: _train_resume(
        p, f, lambda c: (shutil.rmtree(c.parent), p.folder_link_out(c.parent)))))
    cases.append(Case("cli:train", "checkpoint-folder-link-out", lambda p, f: _train_resume(
        p, f, lambda c: (shutil.rmtree(c), p.folder_link_out(c)))))
    return cases


def _move_out(folder: Path, p: Place) -> None:
    """Move ``folder``'s files to the folder outside and leave a link to it in its place."""
    for item in folder.iterdir():
        shutil.move(item, p.victim_dir / item.name)
    folder.rmdir()
    p.folder_link_out(folder)


def _rows(out: Path) -> Path:
    return next((out / "rows").glob("*.jsonl"))


def _score(p: Place, f: dict, tamper: Callable[[Path, Path], Any] = lambda kit, pred: None) -> list[str]:
    base = p.work / "sub"
    shutil.copytree(f["exported"], base, symlinks=True)
    tamper(base / "kit.key.json", base / "pred")
    return ["score", "--manifest", str(base / "kit.key.json"), "--predictions", str(base / "pred"), "--name", "x",
            "--figure-frames", "0", "--out", str(p.work / "run"), "-q"]


def _first_prediction(pred: Path) -> Path:
    return sorted(pred.rglob("*.png"))[0]


def _replace(path: Path, make: Callable[[Path], Any]) -> None:
    path.unlink()
    make(path)


def _fill(p: Place, inputs: list[Path], *more: str) -> list[str]:
    return ["fill", *map(str, inputs), "--out", str(p.work / "out"), "-m", "scanline", "--missing", "-q", *more]


def _py_fill(p: Place, inputs: list[Path], **kw: Any) -> Callable[[], Any]:
    from inpaintenv.filling import fill

    def run() -> None:
        report = fill(inputs, p.work / "out", method="scanline", missing=True, progress=False, log=lambda line: None,
                      **kw)
        for _, why in report.failed:  # a bad file is one line in the report and the run goes on
            assert "\n" not in why and "Traceback" not in why, why
            raise InpaintenvError(why)
    return run


def _killed_between_outputs(p: Place) -> list[str]:
    """A ``--format both`` fill as a SIGKILL after its first output leaves it: the intent line alone, the
    PNG there, the ``.npy`` not; the rerun of the same command must finish it."""
    argv = _fill(p, [p.depth()], "--format", "both")
    assert main(argv) == 0
    ledger = p.work / "out" / "inpaintenv-fill.jsonl"
    intent = next(line for line in ledger.read_text().splitlines() if json.loads(line).get("intent") is True)
    ledger.write_text(intent + "\n")
    (p.work / "out" / "a.npy").unlink()
    return argv


def _none(*done: Any) -> list[str]:
    """No arguments: ``done`` are files made on the way."""
    return []


def _fifo_config(p: Place) -> Path:
    """A model folder whose config.json is a FIFO."""
    folder = p.model()
    (folder / "config.json").unlink()
    p.fifo(folder / "config.json")
    return folder


def _sparse(path: Path, size: int) -> Path:
    """A file that claims ``size`` bytes without using the disk."""
    p = path
    p.parent.mkdir(parents=True, exist_ok=True)
    with open(p, "wb") as f:
        f.truncate(size)
    return p


def _release(name: str, **overrides: Any) -> Callable[[Place, dict], Callable[[], Any]]:
    def call(p: Place, f: dict) -> Callable[[], Any]:
        from estimators.learned import load_release

        return lambda: load_release(name, **overrides)
    return call


def _default(**kwargs: Any) -> Callable[[Place, dict], Callable[[], Any]]:
    def call(p: Place, f: dict) -> Callable[[], Any]:
        from estimators.learned import load_default

        return lambda: load_default(**kwargs)
    return call


def _load(path_of: Callable[[Place], Path]) -> Callable[[Place, dict], Callable[[], Any]]:
    def call(p: Place, f: dict) -> Callable[[], Any]:
        from estimators.learned import load

        path = path_of(p)
        return lambda: load(path)
    return call


def _intervals_load(path_of: Callable[[Place], Path]) -> Callable[[Place, dict], Callable[[], Any]]:
    def call(p: Place, f: dict) -> Callable[[], Any]:
        from estimators.intervals import ConformalIntervalInpainter

        path = path_of(p)
        return lambda: ConformalIntervalInpainter.load(path)
    return call


def _kitti_py(run: Callable[[Path], Any], bad: str) -> Callable[[Place, dict], Callable[[], Any]]:
    return lambda p, f: (lambda root=p.kitti(bad): run(root))


def _gym(root: Path) -> None:
    import gymnasium as gym

    import inpaintenv  # noqa: F401  (registers the env ids)

    env = gym.make("inpaintenv/KittiInpaint-v0", root=str(root))
    try:
        for seed in range(2):
            env.reset(seed=seed)
            env.unwrapped.dataset.load_batch(list(range(len(env.unwrapped.dataset))))
    finally:
        env.close()


def _evaluate(root: Path) -> None:
    from inpaintenv.data import KittiDepth
    from inpaintenv.evaluate import evaluate
    from inpaintenv.methods.registry import make_method

    evaluate(make_method("scanline"), KittiDepth(root), progress=False)


def _fill_depth(depth: Any, mask: Any = None) -> Callable[[Place, dict], Callable[[], Any]]:
    from inpaintenv.filling import fill_depth

    return lambda p, f: (lambda: fill_depth("scanline", depth, mask))


def _cal_edits() -> list[Case]:
    edits = {"nan-quantile": ("quantile", float("nan")), "negative-quantile": ("quantile", -5.0),
             "huge-coef": ("coef", [-1e300] * 4), "negative-residuals": ("residual_quantiles", [-1.0] * 2001),
             "count-not-a-number": ("n_pixels", "many"), "zero-count": ("n_pixels", 0),
             # each number within its bound, the scale they imply millimetres where the residuals were metres
             "intercept-minus-20": ("coef", [-20.0, *json.loads(INTERVALS.read_text())["coef"][1:]])}
    cases = []
    for name, (key, value) in edits.items():
        edit = settable(key, value)
        says = "NaN" if "nan" in name else key
        cases.append(Case("py:ConformalIntervalInpainter.load", name,
                          _intervals_load(lambda p, e=edit: p.intervals(e)), says=says))
        cases.append(Case("cli:fill", f"intervals-{name}", lambda p, f, e=edit: _fill(
            p, [p.depth()], "--confidence", "0.9", "--intervals", str(p.intervals(e))), says=says))
    return cases


def _config_edits() -> list[Case]:
    edits = {"nan-lr": ("lr", float("nan")), "huge-threads": ("num_threads", 1000), "negative-width": ("width", -8),
             "nested": None}
    cases = []
    for name, change in edits.items():
        says = "nested" if change is None else change[0]
        edit = None if change is None else settable(f"params.{change[0]}", change[1])
        if edit is None:
            def folder(p: Place) -> Path:
                return p.write(p.model() / "config.json", NESTED).parent
        else:
            def folder(p: Place, e=edit) -> Path:
                return p.model(e)
        cases.append(Case("py:load", f"config-{name}", _load(folder), says=says))
        cases.append(Case("cli:evaluate", f"checkpoint-config-{name}",
                          lambda p, f, d=folder: ["evaluate", *TINY, "--checkpoint", f"m={d(p)}"], says=says))
    return cases


def _wall(scale: float = 1.0, behind: bool = False) -> np.ndarray:
    """A LiDAR scan of a wall 8-12 m ahead (x forward, y left, z up), scaled, or turned behind the car."""
    az, el = np.meshgrid(np.radians(np.arange(-50, 50, 0.8)), np.radians(np.linspace(3, -15, 16)))
    x = 10 + 2 * np.sin(3 * az)
    pts = np.stack([x, x * np.tan(az), x * np.tan(el) / np.cos(az), np.full_like(x, 0.5)], -1).reshape(-1, 4)
    pts[:, :3] *= scale
    pts[:, 0] *= -1 if behind else 1
    return pts.astype(np.float32)


#: The P lines and Tr of an odometry calib.txt whose camera (120 x 48 px) looks along the LiDAR's x axis.
_FORWARD_P, _FORWARD_TR = "60 0 60 0 0 60 24 0 0 0 1 0", "Tr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n"


def _scan_fill(p: Place, points: np.ndarray, *more: str, p2: str = _FORWARD_P, tr: str = _FORWARD_TR,
               folder: str = "in") -> list[str]:
    """``fill`` of one scan (in ``folder``) with an odometry calibration whose P lines are ``p2`` and Tr ``tr``."""
    scan = p.write(p.work / folder / "s.bin", points.tobytes())
    calib = p.write(p.work / "calib.txt", "".join(f"P{i}: {p2}\n" for i in range(4)) + tr)
    return _fill(p, [scan], "--calib", str(calib), "--size", "120x48", *more)


def _value_cases() -> list[Case]:
    """Values that are well-formed files but impossible values: scan points, calibrations, depth scale."""
    k360 = "2013_05_28_drive_0000_sync/velodyne_points/data"
    metres = np.where(np.random.default_rng(0).random((32, 64)) < 0.3, 40, 0).astype(np.uint16)
    return [
        Case("cli:fill", "scan-one-point-at-1e30", lambda p, f: _scan_fill(
            p, np.vstack([_wall(), [[1e30, 0, 0, 0]]]).astype(np.float32), "--points", "bin"),
             ok=True),
        Case("cli:fill", "scan-in-decimetres", lambda p, f: _scan_fill(p, _wall(30.0)), says="unit mistake"),
        Case("cli:fill", "scan-all-behind", lambda p, f: _scan_fill(p, _wall(behind=True)),
             says="no point of the scan lands in the 120x48 image"),
        Case("cli:fill", "calib-negated-depth-row", lambda p, f: _scan_fill(p, _wall(), p2="60 0 60 0 0 60 24 0 0 0 -1 0"),
             says="not right-handed"),
        Case("cli:fill", "calib-number-beyond-float", lambda p, f: _scan_fill(p, _wall(), p2="1e400 0 60 0 0 60 24 0 0 0 1 0"),
             says="beyond any float"),
        Case("cli:fill", "calib-singular", lambda p, f: _scan_fill(p, _wall(), p2="60 0 60 0 0 60 24 0 0 0 0 0"),
             says="singular"),
        Case("cli:fill", "scan-kitti360-with-odometry-calib", lambda p, f: _scan_fill(p, _wall(), folder=k360),
             says="is a KITTI-360 scan"),
        Case("cli:fill", "calib-rotation-in-millimetres", lambda p, f: _scan_fill(
            p, _wall(), tr="Tr: 0 -1000 0 0 0 0 -1000 0 1000 0 0 0\n"), says="not a rotation"),
        Case("cli:fill", "input-png-of-plain-metres", lambda p, f: _fill(p, [_png_metres(p, metres)]),
             says="plain metres"),
        Case("py:fill", "scan-all-behind", lambda p, f: _py_fill(p, [p.write(p.work / "in" / "s.bin", _wall(
            behind=True).tobytes())], calibration=_py_calibration()), says="no point of the scan lands"),
        Case("py:fill", "scan-in-decimetres", lambda p, f: _py_fill(p, [p.write(p.work / "in" / "s.bin", _wall(
            30.0).tobytes())], calibration=_py_calibration()), says="unit mistake"),
    ]


def _png_metres(p: Place, values: np.ndarray) -> Path:
    from inpaintenv.data.io import write_png

    path = p.work / "in" / "a.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_png(path, values)
    return path


def _py_calibration() -> Any:
    from inpaintenv.data import Calibration

    k = np.array([[60.0, 0, 60], [0, 60, 24], [0, 0, 1]])
    return Calibration(k @ np.array([[0, -1.0, 0, 0], [0, 0, -1, 0], [1, 0, 0, 0]]), (120, 48), "odometry")


#: Hand-edited rows (tests/hostile_rows.py) a resume must refuse, and those of them found through a
#: Dask resume (each such case starts two workers: ~5 s; tests/test_cluster.py runs the whole table
#: through one shared cluster).
RESUMED_ROWS = ("negative-rmse", "nan-rmse", "null-metric", "duplicate-other-protocol", "made-up-drive",
                "seed-true", "negative-count", "psnr-out-of-range", "duplicate-key", "extra-key", "missing-key")
DASK_ROWS = ("duplicate-other-protocol", "made-up-drive", "null-metric", "seed-true")


#: Those a rebuilt report (``inpaintenv report``, no data at hand) refuses too, each in its own words.
REPORTED_ROWS = {"negative-rmse": "hole_rmse", "duplicate-other-protocol": "freeform-v1", "seed-true": "seed",
                 "unplanned-index": "index 999", "duplicate-key": "a second row"}


def _row_cases() -> list[Case]:
    cases = []
    for where, names, more in (("resume", RESUMED_ROWS, []), ("dask-resume", DASK_ROWS, ["--scheduler", "local:2"])):
        for name in names:
            edit, says = HOSTILE_ROWS[name]
            cases.append(Case("cli:benchmark", f"{where}-row-{name}", lambda p, f, e=edit, m=more: [
                *_run_dir(p, f, lambda o: tamper_rows(_rows(o), e)), *m],
                says=rf"line \d+ of .*\.jsonl is not a row of this run: .*{says}"))
    cases.append(Case("cli:report", "results-meta-hand-edited", lambda p, f: _report_dir(p, f, lambda o: p.write(
        o / "results.json", re.sub(r'"meta": \{', '"meta": {"training_drives": {"scanline": 5}, "kinds": [], ',
                                   (o / "results.json").read_text(), count=1))), ok=True))
    for name, says in REPORTED_ROWS.items():
        cases.append(Case("cli:report", f"row-{name}", lambda p, f, e=HOSTILE_ROWS[name][0]: _report_dir(
            p, f, lambda o: tamper_rows(_rows(o), e)), says=rf"line \d+ of .*\.jsonl is not a row of this run: .*{says}"))
    return cases


CASES: list[Case] = [
    # info, evaluate, show, export, benchmark, train: a KITTI tree holding one hostile frame
    *[Case(f"cli:{cmd[0]}", f"kitti-{bad}", _cli_kitti(cmd, bad), ok=bad == "not-utf8")
      for cmd in (["info", "--sample", "2"], ["evaluate", "-m", "scanline"], ["show", "-m", "scanline", "--index", "1"],
                  ["export", "--holdout", "0"], ["benchmark", "--holdout", "0", "-m", "scanline", "--figure-frames", "0"],
                  ["train", "--preset", "smoke"])
      for bad in ("fifo", "bomb", "not-utf8")],
    # evaluate / benchmark / score / train: files of the run folder the command owns
    Case("cli:evaluate", "run.lock-link-out", lambda p, f: ["evaluate", *TINY, "-m", "scanline", "--out",
                                                          str(p.link_out(p.work / "e" / "run.lock").parent)]),
    Case("cli:evaluate", "results-link-out", lambda p, f: ["evaluate", *TINY, "-m", "scanline", "--out",
                                                         str(p.link_out(p.work / "e" / "results.json").parent)],
         ok=True, says="symbolic link|neither empty nor a run folder"),
    Case("cli:benchmark", "run.lock-link-out", lambda p, f: _run_dir(p, f, lambda o: _replace(
        o / "run.lock", p.link_out))),
    Case("cli:benchmark", "rows-link-out", lambda p, f: _run_dir(p, f, lambda o: _replace(_rows(o), p.link_out))),
    Case("cli:benchmark", "rows-folder-link-out", lambda p, f: [*_run_dir(p, f, lambda o: _move_out(
        o / "rows", p)), "-m", "nearest"], says="symbolic link|link"),
    Case("cli:benchmark", "rows-fifo", lambda p, f: _run_dir(p, f, lambda o: _replace(_rows(o), p.fifo))),
    Case("cli:benchmark", "run.json-nested", lambda p, f: _run_dir(p, f, lambda o: p.write(o / "run.json", NESTED))),
    Case("cli:benchmark", "run.json-fifo", lambda p, f: _run_dir(p, f, lambda o: _replace(o / "run.json", p.fifo))),
    Case("cli:benchmark", "files-ledger-nested", lambda p, f: _run_dir(
        p, f, lambda o: p.write(o / "inpaintenv-files.json", NESTED))),
    Case("cli:benchmark", "results-link-out", lambda p, f: _run_dir(
        p, f, lambda o: _replace(o / "results.json", p.link_out)), ok=True),
    Case("cli:benchmark", "run.json-nan", lambda p, f: _run_dir(p, f, lambda o: p.write(
        o / "run.json", re.sub(r'"n_frames": \d+', '"n_frames": NaN', (o / "run.json").read_text())))),
    Case("cli:report", "rows-fifo", lambda p, f: _report_dir(p, f, lambda o: _replace(_rows(o), p.fifo))),
    Case("cli:report", "rows-link-out", lambda p, f: _report_dir(p, f, lambda o: _replace(_rows(o), p.link_out))),
    Case("cli:report", "results-nested", lambda p, f: _report_dir(p, f, lambda o: p.write(o / "results.json", NESTED)),
         ok=True),  # the page is built without what results.json would add
    Case("cli:report", "report-link-out", lambda p, f: _report_dir(
        p, f, lambda o: _replace(o / "report.html", p.link_out)), ok=True),  # replaced, never written through
    Case("cli:report", "figure-link-out", lambda p, f: _report_dir(
        p, f, lambda o: p.link_out(o / "figures" / "frame_0000.png")), says="symbolic link|no inpaintenv run wrote"),
    Case("cli:score", "run.lock-link-out", lambda p, f: _score(p, f, lambda k, d: p.link_out(
        p.work / "run" / "run.lock"))),
    Case("cli:train", "run.lock-link-out", lambda p, f: [
        "train", "--preset", "smoke", *TINY, "--out", str(p.link_out(p.work / "t" / "run.lock").parent)]),
    Case("cli:train", "train_args-nested", lambda p, f: [
        "train", "--preset", "smoke", *TINY, "--out", str(p.write(p.work / "t" / "train_args.json", NESTED).parent)],
         says="nested|neither empty nor a run folder"),
    Case("cli:train", "train_args-fifo", lambda p, f: [
        "train", "--preset", "smoke", *TINY, "--out", str(p.fifo(p.work / "t" / "train_args.json").parent)],
         says="FIFO|neither empty nor a run folder"),
    Case("cli:train", "set-nan-lr", lambda p, f: [
        "train", "--preset", "smoke", *TINY, "--set", "lr=NaN", "--out", str(p.work / "t")], says="lr"),
    Case("cli:train", "huge-threads", lambda p, f: [
        "train", "--preset", "smoke", *TINY, "--threads", "100000", "--out", str(p.work / "t")], says="threads"),
    Case("cli:show", "out-link-out", lambda p, f: ["show", *TINY, "--out", str(p.link_out(p.work / "panel.png"))],
         ok=True),
    # export: its --out, its key
    # temp-looking names whose pid does not parse: left alone, the command runs (was a traceback)
    Case("cli:export", "partial-name-23-digit-pid", lambda p, f: [
        "export", *TINY, "--holdout", "0", "--out", str(p.work / "kit"),
        *_none(p.write(p.work / f".kit.partial-{'1' * 23}" / "x", b"x"), p.write(p.work / ".kit.partial-\u00b2", b"x"))],
         ok=True, says=SUCCESS_ONLY),
    Case("cli:export", "out-inside-the-data-root", lambda p, f: [
        "export", "--kitti-root", str(p.kitti()), "--holdout", "0", "--out", str(p.work / "kitti" / "train" / "kit"), "-q"],
         says="inside the data root"),
    Case("cli:export", "manifest-fifo", lambda p, f: [
        "export", *TINY, "--holdout", "0", "--overwrite", "--out", str(p.fifo(p.work / "kit" / "manifest.json").parent)]),
    Case("cli:export", "manifest-nested", lambda p, f: [
        "export", *TINY, "--holdout", "0", "--overwrite", "--out", str(p.write(p.work / "kit" / "manifest.json", NESTED).parent)]),
    Case("cli:export", "key-link-out", lambda p, f: [
        "export", *TINY, "--holdout", "0", "--out", str(p.work / "kit"), "--key", str(p.link_out(p.work / "kit.key.json"))],
         says="symbolic link|not a plain file"),
    # score: the key, the predictions
    Case("cli:score", "key-kit-out-of-folder", lambda p, f: _score(p, f, lambda k, d: p.write(k, json.dumps(
        {**json.loads(k.read_text()), "kit": "../../../../../../../../etc"}))), says="holds no export"),
    Case("cli:score", "prediction-upper-case-png", lambda p, f: _score(p, f, lambda k, d: shutil.copy(
        _first_prediction(d), _first_prediction(d).with_name("0000000099.PNG"))), says=r"0000000099\.PNG"),
    Case("cli:score", "prediction-nfc-nfd-twins", lambda p, f: _score(p, f, lambda k, d: [shutil.copy(
        _first_prediction(d), _first_prediction(d).with_name(n)) for n in ("caf\u00e9.png", "cafe\u0301.png")]),
         says=r"cafe\\u0301\.png\].*caf\\xe9\.png\]|caf\\xe9\.png\].*cafe\\u0301\.png\]"),
    Case("cli:score", "key-fifo", lambda p, f: _score(p, f, lambda k, d: _replace(k, p.fifo))),
    Case("cli:score", "key-nested", lambda p, f: _score(p, f, lambda k, d: p.write(k, NESTED))),
    Case("cli:score", "key-nan-seed", lambda p, f: _score(p, f, lambda k, d: p.write(
        k, k.read_text().replace('"seeds": [\n  0\n ]', '"seeds": [NaN]')))),
    Case("cli:score", "key-huge-shape", lambda p, f: _score(p, f, lambda k, d: p.write(
        k, json.dumps({**json.loads(k.read_text()), "frame_shape": [10**9, 10**9]}))), says="1000000000"),
    Case("cli:score", "key-negative-index", lambda p, f: _score(p, f, lambda k, d: p.write(
        k, k.read_text().replace('"index": 1', '"index": -1', 1))), says="index"),
    Case("cli:score", "prediction-bomb", lambda p, f: _score(p, f, lambda k, d: p.write(_first_prediction(d), BOMB))),
    Case("cli:score", "prediction-fifo", lambda p, f: _score(p, f, lambda k, d: _replace(_first_prediction(d), p.fifo))),
    Case("cli:score", "prediction-link-out", lambda p, f: _score(
        p, f, lambda k, d: _replace(_first_prediction(d), p.link_out))),
    Case("cli:score", "prediction-not-utf8", lambda p, f: _score(
        p, f, lambda k, d: shutil.copy(_first_prediction(d), _first_prediction(d).with_name(f"{NOT_UTF8}.png"))),
         says=r"caf\\xe9\.png"),  # an extra file, named as it is
    # fill: inputs, masks, outputs, models, calibrations
    Case("cli:fill", "out-temp-name-unparseable-pid", lambda p, f: _fill(p, [p.depth()], *_none(
        p.write(p.work / "out" / ".inpaintenv-tmp-\u00b2-abc.png", b"x"),
        p.write(p.work / "out" / f".inpaintenv-tmp-{'1' * 23}-abc.png", b"x"))), ok=True, says=SUCCESS_ONLY),
    Case("cli:fill", "killed-between-outputs", lambda p, f: _killed_between_outputs(p), ok=True, says=SUCCESS_ONLY),
    Case("cli:fill", "calib-mistyped", lambda p, f: _fill(p, [p.write(p.work / "in" / f"s{k}.bin", np.ones(
        (4, 4), np.float32).tobytes()).parent for k in range(2)][-1:], "--calib", str(p.work / "nowhere")),
         says="--calib .*nowhere: no such calibration"),
    Case("cli:fill", "two-drives-same-inner-paths", lambda p, f: _fill(p, [
        p.depth(f"d{k}/image_02/0000000000.png").parents[1] for k in (1, 2)]), says="same output.*as one INPUT"),
    Case("cli:fill", "ledger-outputs-not-paths", lambda p, f: _fill(p, [p.depth()], *_none(p.write(
        p.work / "out" / "inpaintenv-fill.jsonl", '{"outputs": [{}], "input": {}}\n{"outputs": ["../../victim.txt"], '
        '"input": {}, "intent": true}\n'))), ok=True, says=SUCCESS_ONLY),
    Case("cli:fill", "input-fifo", lambda p, f: _fill(p, [p.fifo(p.work / "in" / "a.png")])),
    Case("cli:fill", "input-fifo-in-folder", lambda p, f: _fill(p, [p.fifo(p.work / "in" / "a.png").parent])),
    Case("cli:fill", "input-bomb", lambda p, f: _fill(p, [p.write(p.work / "in" / "a.png", BOMB)])),
    Case("cli:fill", "input-npy-bomb", lambda p, f: _fill(p, [p.write(p.work / "in" / "a.npy", NPY_BOMB)])),
    Case("cli:fill", "input-not-utf8", lambda p, f: _fill(p, [p.depth(f"{NOT_UTF8}.png")]), ok=True),
    Case("cli:fill", "mask-bomb", lambda p, f: _fill(p, [p.depth()], "--holes", str(p.write(
        p.work / "m.png", MASK_BOMB)))),
    Case("cli:fill", "mask-fifo", lambda p, f: _fill(p, [p.depth()], "--holes", str(p.fifo(p.work / "m.png")))),
    Case("cli:fill", "mask-not-utf8", lambda p, f: _fill(p, [p.depth()], "--holes", str(p.write(
        p.work / f"{NOT_UTF8}.png", png(64, 32, 8, 0, b"\0" * (65 * 32))))), ok=True),
    Case("cli:fill", "out-folder-link-out", lambda p, f: _fill(p, [p.work / "in"], *_none(
        p.depth("sub/a.png"), p.folder_link_out(p.work / "out" / "sub"))), says="symbolic link|link"),
    Case("cli:fill", "output-link-out", lambda p, f: _fill(p, [p.depth()], "--overwrite", *_none(
        p.link_out(p.work / "out" / "a.png"))), ok=True),
    Case("cli:fill", "preview-link-out", lambda p, f: _fill(p, [p.depth()], "--preview", "--overwrite", *_none(
        p.link_out(p.work / "out" / "a_preview.png"))), ok=True),  # replaced, never written through
    Case("cli:fill", "intervals-fifo", lambda p, f: _fill(p, [p.depth()], "--confidence", "0.9", "--intervals",
                                                          str(p.fifo(p.work / "cal.json")))),
    Case("cli:fill", "intervals-nested", lambda p, f: _fill(p, [p.depth()], "--confidence", "0.9", "--intervals",
                                                            str(p.write(p.work / "cal.json", NESTED)))),
    Case("cli:fill", "checkpoint-config-fifo", lambda p, f: [
        "fill", str(p.depth()), "--out", str(p.work / "out"), "--missing", "-q", "--checkpoint", str(_fifo_config(p))]),
    Case("cli:fill", "scan-huge", lambda p, f: _fill(p, [_sparse(p.work / "in" / "s.bin", 3 << 30)], "--calib",
                                                     str(p.work)), says="3,221,225,472"),
    Case("cli:fill", "size-huge", lambda p, f: _fill(p, [p.write(p.work / "in" / "s.bin", np.ones(
        (10, 4), np.float32).tobytes())], "--calib", str(p.write(p.work / "calib.txt", ODOMETRY)), "--size",
        "32768x32768"), says="pixels"),
    Case("cli:fill", "calib-fifo", lambda p, f: _fill(p, [p.write(p.work / "in" / "s.bin", np.ones(
        (10, 4), np.float32).tobytes())], "--calib", str(p.fifo(p.work / "calib.txt")), "--size", "64x32")),
    Case("py:fill", "input-fifo", lambda p, f: _py_fill(p, [p.fifo(p.work / "in" / "a.png")])),
    Case("py:fill", "input-bomb", lambda p, f: _py_fill(p, [p.write(p.work / "in" / "a.png", BOMB)])),
    Case("py:fill", "input-not-utf8", lambda p, f: _py_fill(p, [p.depth(f"{NOT_UTF8}.png")]), ok=True),
    Case("py:fill", "mask-bomb", lambda p, f: _py_fill(p, [p.depth()], holes=p.write(p.work / "m.png", MASK_BOMB))),
    Case("py:fill_depth", "nan-everywhere", _fill_depth(np.full((8, 8), np.nan)), says="no measurement"),
    Case("py:fill_depth", "negative", _fill_depth(np.full((8, 8), -3.0)), says="negative"),
    Case("py:fill_depth", "huge", _fill_depth(np.full((8, 8), 1e300)), says=r"1e\+300"),
    Case("py:fill_depth", "object-array", _fill_depth(np.array([[None, "x"]], dtype=object)), says="object"),
    Case("py:fill_depth", "wrong-mask", _fill_depth(np.ones((8, 8), np.float32), np.ones((8, 8, 3), bool)),
         says="shape"),
    *_cal_edits(),
    *_config_edits(),
    *_value_cases(),
    *_training_states(),
    *_row_cases(),
    Case("py:ConformalIntervalInpainter.load", "fifo", _intervals_load(lambda p: p.fifo(p.work / "cal.json"))),
    Case("py:ConformalIntervalInpainter.load", "nested", _intervals_load(lambda p: p.write(p.work / "c.json", NESTED))),
    Case("py:ConformalIntervalInpainter.load", "not-utf8-name", _intervals_load(
        lambda p: p.write(p.work / f"{NOT_UTF8}.json", INTERVALS.read_bytes())), ok=True),
    Case("py:load", "config-fifo", _load(_fifo_config)),
    Case("py:load", "state-nested", _load(lambda p: p.write(p.work / "run" / "state.json", NESTED).parent)),
    Case("py:load", "state-fifo", _load(lambda p: p.fifo(p.work / "run" / "state.json").parent)),
    Case("py:load", "state-nan", _load(lambda p: p.write(p.work / "run" / "state.json",
                                                         '{"last": NaN, "best": NaN}').parent), says="NaN|last"),
    Case("py:load", "not-utf8-folder", _load(lambda p: p.model(name=NOT_UTF8)), ok=True),
    Case("py:load_release", "name-out-of-folder", _release("../pretrained/kitti-mixed-v1"), says="no shipped release"),
    Case("py:load_release", "name-not-utf8", _release(NOT_UTF8), says="no shipped release"),
    Case("py:load_release", "huge-threads", _release("kitti-mixed-v1", num_threads=1000), says="num_threads"),
    Case("py:load_release", "negative-threads", _release("kitti-mixed-v1", num_threads=-3), says="num_threads"),
    Case("py:load_default", "huge-threads", _default(num_threads=1000), says="num_threads"),
    *[Case("py:gym", f"kitti-{bad}", _kitti_py(_gym, bad), ok=bad == "not-utf8") for bad in ("fifo", "bomb", "not-utf8")],
    *[Case("py:evaluate", f"kitti-{bad}", _kitti_py(_evaluate, bad), ok=bad == "not-utf8")
      for bad in ("fifo", "bomb", "not-utf8")],
]

#: Cases that still fail, with why and whose fix they wait for: each runs as xfail(strict=True),
#: so the day it passes the test says to take it out of this set.
KNOWN_OPEN: dict[str, str] = {}


def _params() -> list[Any]:
    ids = [c.id for c in CASES]
    assert len(set(ids)) == len(ids), "two cases of one id"
    return [pytest.param(c, id=c.id, marks=[pytest.mark.xfail(strict=True, reason=KNOWN_OPEN[c.id])]
                         if c.id in KNOWN_OPEN else []) for c in CASES]


# -- running a case ------------------------------------------------------------------------------

def _unblock(fifos: list[Path]) -> None:
    """Open each FIFO for writing once, so a reader still blocked on it (a worker thread) gets EOF."""
    for fifo in fifos:
        try:
            fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
        except OSError:
            continue  # no reader waits
        os.close(fd)


def _cli(argv: list[str], capsys) -> tuple[int, str]:
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse: exit status 2 with its usage
        status = exc.code if isinstance(exc.code, int) else 1
    return status, capsys.readouterr().err


def _check_cli(case: Case, status: int, err: str) -> None:
    """Exit status 1 with one error line (``inpaintenv <command>: ...``; what the command said it
    was doing before may precede it), or argparse's 2; no traceback, no warning."""
    assert "Traceback" not in err and "Warning" not in err, f"{case.id}:\n{err}"
    if status == 0 and case.ok:
        return
    assert status in (1, 2), f"{case.id}: exit status {status}, stderr:\n{err}"
    errors = [line for line in err.splitlines() if line.startswith("inpaintenv ")]
    assert len(errors) == 1, f"{case.id}: {len(errors)} error lines on stderr, not one:\n{err}"
    assert re.search(case.names, errors[0]), f"{case.id}: the error does not name the problem ({case.names}):\n{err}"


def _check_py(case: Case, run: Callable[[], Any]) -> None:
    try:
        run()
    except (InpaintenvError, OSError) as exc:
        assert re.search(case.names, str(exc)), f"{case.id}: the error does not name the problem ({case.names}): {exc}"
        return
    if not case.ok:
        pytest.fail(f"{case.id}: no error")


# The limit times the case, not the module's runs it copies (set up once, untimed: the first
# case to need them would pay a benchmark, an export and a training).
@pytest.mark.timeout(TIME_LIMIT, func_only=True)
@pytest.mark.parametrize("case", _params())
def test_hostile_file_is_one_clear_error(case, tmp_path, capsys, monkeypatch, benchmark_run, exported, train_run):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    place = Place(tmp_path)
    place.work.mkdir()
    monkeypatch.chdir(place.work)  # a default output folder (runs/model, panel.png) lands in the case's folder
    place.victim.write_bytes(VICTIM)
    os.chmod(place.victim, stat.S_IRUSR | stat.S_IWUSR)
    place.victim_dir.mkdir()
    (place.victim_dir / "mine.txt").write_bytes(VICTIM)
    fixtures = {"benchmark_run": benchmark_run, "exported": exported, "train_run": train_run}
    try:
        call = case.call(place, fixtures)
        before = place.outside()
        if isinstance(call, list):
            _check_cli(case, *_cli(call, capsys))
        else:
            _check_py(case, call)
    finally:
        _unblock(place.fifos)
    assert place.victim.read_bytes() == VICTIM, f"{case.id} wrote through a link into a file outside its folder"
    assert place.outside() == before, f"{case.id} wrote outside its folder"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["victim.txt", "victim_dir", "work"], \
        f"{case.id} wrote outside its folder: {sorted(p.name for p in tmp_path.iterdir())}"


# -- the table is complete -----------------------------------------------------------------------

def test_every_entry_point_is_in_the_table():
    """A new subcommand, env id or loader of checkpoints must get its row in :data:`CASES`."""
    import estimators.learned as learned
    from inpaintenv.envs import ENV_IDS

    entries = {c.entry for c in CASES}
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    missing = {f"cli:{name}" for name in commands} - entries
    assert not missing, f"CLI subcommands with no hostile-file case: {sorted(missing)}"
    loaders = {f"py:{name}" for name in learned.__all__ if name.startswith("load")}
    assert loaders <= entries, f"checkpoint loaders with no case: {sorted(loaders - entries)}"
    assert {"py:gym", "py:evaluate", "py:fill", "py:fill_depth", "py:ConformalIntervalInpainter.load"} <= entries
    assert len(ENV_IDS) == 3, f"a new env id: give its data source a case in the table ({sorted(ENV_IDS)})"
