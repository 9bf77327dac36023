"""Distributed evaluation on a real Dask LocalCluster (two worker processes on 127.0.0.1).

One cluster serves the module (starting it costs seconds); the test that kills a worker
waits for the nanny to bring the worker back, so later tests see two workers again.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shutil
import signal
import sys
import threading
import time

import numpy as np
import pytest
from hostile_rows import HOSTILE_ROWS, tamper_rows

distributed = pytest.importorskip("distributed")

from estimators.classical import NearestInpainter
from inpaintenv import cluster
from inpaintenv.benchmark import run_benchmark
from inpaintenv.cli import main
from inpaintenv.cluster import (
    ClusterError,
    WorkerDataError,
    open_client,
    parse_scheduler,
)
from inpaintenv.data import KittiDepth, SyntheticStreets
from inpaintenv.data.io import write_depth_png
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import MethodOutputError, ResultRowError, RunStateError

pytestmark = pytest.mark.timeout(120)

SHAPE = (48, 96)


class SlowNearest:
    """Nearest fill that sleeps per batch, so a run lasts long enough to kill a worker in it."""

    batched = True
    name = "slow-nearest"

    def __init__(self, seconds: float):
        self.seconds = seconds

    def __call__(self, x: np.ndarray) -> np.ndarray:
        time.sleep(self.seconds)
        return NearestInpainter(n_jobs=1).predict(x)


class StopsOnFlag:
    """Nearest fill that returns NaN (an unusable output) while ``flag`` exists: a run that
    fails part-way, leaving some rows written."""

    batched = True
    name = "stops-on-flag"

    def __init__(self, flag: str):
        self.flag = flag

    def __call__(self, x: np.ndarray) -> np.ndarray:
        time.sleep(0.1)
        if os.path.exists(self.flag):
            return np.full_like(x, np.nan)
        return NearestInpainter(n_jobs=1).predict(x)


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1", dashboard_address="127.0.0.1:0",
    ) as local, distributed.Client(local) as c:
        yield c


@pytest.fixture(scope="module")
def streets():
    return SyntheticStreets(n=12, frame_shape=SHAPE)


def without_ms(rows):
    """Rows as JSON text without the wall-clock column (NaN == NaN, bit-exact floats)."""
    return [json.dumps({k: v for k, v in r.items() if k != "ms"}, sort_keys=True) for r in rows]


def read_row_file(path):
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_evaluate_on_cluster_gives_the_serial_rows(client, streets):
    kw = {"protocol": "freeform-v1", "seeds": [0, 2], "batch_size": 3, "progress": False}
    got = []
    dist = evaluate(NearestInpainter(n_jobs=1), streets, client=client, on_batch=got.append, **kw)
    serial = evaluate(NearestInpainter(n_jobs=1), streets, **kw)
    assert without_ms(dist.rows) == without_ms(serial.rows)
    assert dist.meta == serial.meta
    # Rows streamed back batch by batch: one call per batch of 3 frames, every seed in it.
    assert sorted(len(b) for b in got) == [6] * 4
    assert sorted((r["seed"], r["index"]) for b in got for r in b) == sorted(
        (r["seed"], r["index"]) for r in serial.rows
    )


def test_run_benchmark_on_cluster_writes_the_serial_row_files(client, streets, tmp_path):
    methods = {"nearest": NearestInpainter(n_jobs=1), "slow": SlowNearest(0.0)}
    kw = {"protocols": ["rect-v1", "lidar-dropout-v1"], "seeds": [1], "batch_size": 4, "progress": False}
    dist = run_benchmark(methods, streets, out_dir=tmp_path / "dist", client=client, **kw)
    serial = run_benchmark(methods, streets, out_dir=tmp_path / "serial", **kw)
    assert without_ms(dist.rows) == without_ms(serial.rows)
    for path in sorted((tmp_path / "serial" / "rows").glob("*.jsonl")):
        other = tmp_path / "dist" / "rows" / path.name
        key = lambda r: (r["seed"], r["index"])
        assert without_ms(sorted(read_row_file(other), key=key)) == without_ms(sorted(read_row_file(path), key=key))


@pytest.mark.slow
def test_torch_method_on_workers_gives_the_serial_rows(client):
    pytest.importorskip("torch")
    from inpaintenv.methods.registry import make_method

    method = make_method("pretrained")  # a learned model: torch on the workers
    source = SyntheticStreets(n=4, frame_shape=(96, 320))
    dist = evaluate(method, source, batch_size=2, progress=False, client=client)
    serial = evaluate(method, source, batch_size=2, progress=False)
    assert without_ms(dist.rows) == without_ms(serial.rows)


def test_cli_benchmark_with_scheduler_address(client, tmp_path, capsys):
    args = ["benchmark", "-m", "nearest", "-m", "constant", "--n-frames", "8", "--frame-shape", *map(str, SHAPE),
            "--holdout", "0", "--figure-frames", "0", "-q"]
    assert main([*args, "--out", str(tmp_path / "serial")]) == 0
    assert main([*args, "--out", str(tmp_path / "dist"), "--scheduler", client.scheduler.address]) == 0
    serial = json.loads((tmp_path / "serial" / "results.json").read_text())["rows"]
    dist = json.loads((tmp_path / "dist" / "results.json").read_text())["rows"]
    assert len(dist) == 16 and without_ms(dist) == without_ms(serial)


def _worker_pids(client):
    return client.run(os.getpid)


def test_sigkilled_worker_loses_no_row(client, tmp_path):
    source = SyntheticStreets(n=16, frame_shape=SHAPE)
    kw = {"protocols": ["rect-v1"], "seeds": [0, 1], "batch_size": 2, "progress": False}
    out = tmp_path / "dist"
    rows_file = out / "rows" / "slow__rect-v1.jsonl"
    pids = _worker_pids(client)
    killed: list[str] = []

    def kill_a_busy_worker():
        # Once the first batch has landed, SIGKILL a worker while it runs a batch.
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not killed:
            if rows_file.exists() and rows_file.stat().st_size:
                busy = [w for w, tasks in client.processing().items() if tasks]
                if busy:
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    killed.append(busy[0])
            time.sleep(0.01)

    killer = threading.Thread(target=kill_a_busy_worker)
    killer.start()
    try:
        dist = run_benchmark({"slow": SlowNearest(0.3)}, source, out_dir=out, client=client, **kw)
    finally:
        killer.join()
    assert killed, "no worker was killed mid-run"
    assert len(_worker_pids(client)) <= 2
    keys = [(r["seed"], r["index"]) for r in read_row_file(rows_file)]
    assert sorted(keys) == sorted((s, i) for s in (0, 1) for i in range(16))  # every row exactly once
    serial = run_benchmark({"slow": SlowNearest(0.0)}, source, out_dir=tmp_path / "serial", **kw)
    assert without_ms(dist.rows) == without_ms(serial.rows)
    client.wait_for_workers(2, timeout=60)  # the nanny restarts the killed worker


def test_failed_distributed_run_resumes_with_every_row_once(client, tmp_path):
    source = SyntheticStreets(n=16, frame_shape=SHAPE)
    flag = tmp_path / "stop"
    method = {"stops": StopsOnFlag(str(flag))}
    kw = {"protocols": ["rect-v1"], "seeds": [0, 1], "batch_size": 2, "progress": False}
    out = tmp_path / "dist"
    rows_file = out / "rows" / "stops__rect-v1.jsonl"

    def stop_after_first_rows():
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not (rows_file.exists() and rows_file.stat().st_size):
            time.sleep(0.01)
        flag.touch()

    stopper = threading.Thread(target=stop_after_first_rows)
    stopper.start()
    try:
        with pytest.raises(MethodOutputError):
            run_benchmark(method, source, out_dir=out, client=client, **kw)
    finally:
        stopper.join()
    first = read_row_file(rows_file)
    assert 0 < len(first) < 32
    flag.unlink()
    resumed = run_benchmark(method, source, out_dir=out, client=client, **kw)
    keys = [(r["seed"], r["index"]) for r in read_row_file(rows_file)]
    assert sorted(keys) == sorted((s, i) for s in (0, 1) for i in range(16))  # every row exactly once
    serial = run_benchmark(method, source, out_dir=tmp_path / "serial", **kw)
    assert without_ms(resumed.rows) == without_ms(serial.rows)


@pytest.mark.slow
def test_local_scheduler_listens_on_loopback_only(streets):
    with open_client("local:1") as local:
        addresses = [local.scheduler.address, *local.nthreads()]
        assert all(a.startswith("tcp://127.0.0.1:") for a in addresses), addresses
        assert local.nthreads() and set(local.nthreads().values()) == {1}
        # Dask's default (65536) made every frame-sized array a fresh mmap: 2x slower.
        assert set(local.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_").values()) == {None}
        dist = evaluate(NearestInpainter(n_jobs=1), streets, n_frames=4, progress=False, client=local)
    serial = evaluate(NearestInpainter(n_jobs=1), streets, n_frames=4, progress=False)
    assert without_ms(dist.rows) == without_ms(serial.rows)


def _tiny_kitti(root, n=4):
    rng = np.random.default_rng(0)
    folder = root / "train" / "2011_09_26_drive_0001_sync" / "proj_depth" / "groundtruth" / "image_02"
    folder.mkdir(parents=True)
    for i in range(n):
        depth = np.where(rng.random(SHAPE) < 0.3, rng.uniform(2, 60, SHAPE), 0.0)
        write_depth_png(folder / f"{i:010d}.png", depth)


def test_worker_that_cannot_read_the_data_fails_with_one_line(client, tmp_path):
    root = tmp_path / "kitti"
    _tiny_kitti(root)
    dataset = KittiDepth(root, crop=None)  # validated here, on the client
    # The workers then see no data at this path (e.g. another machine without the mount).
    shutil.move(root, tmp_path / "elsewhere")
    start = time.monotonic()
    with pytest.raises(WorkerDataError) as info:
        evaluate(NearestInpainter(n_jobs=1), dataset, progress=False, client=client)
    assert time.monotonic() - start < 30
    message = str(info.value)
    assert "\n" not in message
    assert re.search(r"worker tcp://127\.0\.0\.1:\d+ cannot read the data", message)
    assert str(root / "train" / "2011_09_26_drive_0001_sync") in message


def test_skipped_bad_frames_come_back_from_the_workers(client, tmp_path):
    root = tmp_path / "kitti"
    _tiny_kitti(root, n=6)
    bad = sorted(root.rglob("*.png"))[2]
    dataset = KittiDepth(root, crop=None)
    bad.write_bytes(b"not a png")  # corrupt after indexing, as a damaged file would be
    kw = {"seeds": [0, 1], "batch_size": 2, "progress": False, "on_bad_frame": "skip"}
    dist = evaluate(NearestInpainter(n_jobs=1), dataset, client=client, **kw)
    serial = evaluate(NearestInpainter(n_jobs=1), dataset, **kw)
    assert [r["index"] for r in dist.meta["skipped_frames"]] == [2]
    assert dist.meta == serial.meta
    assert without_ms(dist.rows) == without_ms(serial.rows) and len(dist.rows) == 2 * 5


def test_cli_reports_a_worker_read_error_in_one_line(client, tmp_path, monkeypatch, capsys):
    root = tmp_path / "kitti"
    _tiny_kitti(root)
    real = KittiDepth.__init__

    def init_then_unmount(self, *args, **kwargs):
        real(self, *args, **kwargs)
        shutil.move(root, tmp_path / "elsewhere")

    monkeypatch.setattr(KittiDepth, "__init__", init_then_unmount)
    rc = main(["evaluate", "-m", "nearest", "--kitti-root", str(root), "-q", "--scheduler", client.scheduler.address])
    err = capsys.readouterr().err.strip()
    assert rc == 1
    assert len(err.splitlines()) == 1 and "worker tcp://127.0.0.1:" in err and str(root) in err


def _start_scheduler_and_worker(tmp_path):
    """A scheduler and one worker as processes of their own (so the test can kill the scheduler)."""
    import subprocess

    tests_dir = os.path.dirname(os.path.abspath(__file__))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.path.dirname(tests_dir), tests_dir,
                                                        os.environ.get("PYTHONPATH", "")])}
    log = (tmp_path / "scheduler.log").open("w")
    sched = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                              "--port", "0", "--no-dashboard"], stdout=log, stderr=subprocess.STDOUT, env=env)
    deadline, address = time.monotonic() + 60, None
    while address is None and time.monotonic() < deadline:
        found = re.search(r"Scheduler at:\s+(tcp://\S+)", (tmp_path / "scheduler.log").read_text())
        address = found.group(1) if found else time.sleep(0.1)
    assert address, "the scheduler did not start"
    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                               "--no-dashboard", "--host", "127.0.0.1"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, env=env)
    return sched, worker, address


def test_killed_scheduler_is_one_line_and_the_run_resumes(client, tmp_path, monkeypatch, capfd, caplog):
    # Kill -9 of the scheduler ended in a FuturesCancelledError traceback, and
    # distributed's own log lines (tracebacks of the lost connection) came before that line; capfd
    # sees them, as they are written to the stderr of the process, not to sys.stderr as replaced here.
    from inpaintenv.benchmark import suites

    monkeypatch.setattr(suites, "build_method", lambda name, overrides: SlowNearest(0.3))
    out = tmp_path / "run"
    rows_file = out / "rows" / "nearest__rect-v1.jsonl"
    args = ["benchmark", "-m", "nearest", "--n-frames", "16", "--frame-shape", *map(str, SHAPE), "--holdout", "0",
            "--seed", "0", "--seed", "1", "--batch-size", "2", "--figure-frames", "0", "-q", "--out", str(out)]
    sched, worker, address = _start_scheduler_and_worker(tmp_path)
    killed: list[int] = []

    def kill_the_scheduler():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not (rows_file.exists() and rows_file.stat().st_size):
            time.sleep(0.01)
        os.kill(sched.pid, signal.SIGKILL)
        killed.append(sched.pid)

    killer = threading.Thread(target=kill_the_scheduler)
    killer.start()
    try:
        rc = main([*args, "--scheduler", address])
    finally:
        killer.join()
        for proc in (worker, sched):
            proc.kill()
            proc.wait()
    err = capfd.readouterr().err.strip()
    assert killed and rc == 1
    assert len(err.splitlines()) == 1, err
    noisy = [r for r in caplog.records if r.name.split(".")[0] in ("distributed", "tornado")
             and r.levelno >= logging.WARNING]
    assert not noisy, [f"{r.name}: {r.getMessage()}" for r in noisy]
    assert f"the connection to the Dask scheduler at {address} was lost mid-run; the rows scored before are kept" in err
    first = read_row_file(rows_file)
    assert 0 < len(first) < 32
    # The same command on a live cluster resumes: every row exactly once.
    assert main([*args, "--scheduler", client.scheduler.address]) == 0
    keys = [(r["seed"], r["index"]) for r in read_row_file(rows_file)]
    assert sorted(keys) == sorted((s, i) for s in (0, 1) for i in range(16))


def test_asyncio_error_of_a_client_closed_mid_run_is_one_line(client, monkeypatch):
    # Closing the client while a result is awaited can fail inside asyncio ("bound to a
    # different event loop", seen in CI) instead of with ClosedClientError: the same lost run.
    other = distributed.Client(client.scheduler.address)

    def close_then_fail(dd, future, owner, address):
        owner.close()
        raise RuntimeError("<asyncio.locks.Event object> is bound to a different event loop")

    monkeypatch.setattr(cluster, "_result", close_then_fail)
    with pytest.raises(ClusterError, match=r"^the Dask client was closed mid-run; the rows scored before are kept"):
        cluster.map_shards(other, abs, [-1, -2], shared={})

    def method_error(dd, future, owner, address):
        raise RuntimeError("the method's own error")

    monkeypatch.setattr(cluster, "_result", method_error)
    with pytest.raises(RuntimeError, match="the method's own error"):  # client running: unchanged
        cluster.map_shards(client, abs, [-1], shared={})


def test_client_closed_mid_run_is_one_line(client, streets):
    # close() mid-evaluate raised ClosedClientError from the cleanup, hiding the cause.
    got = []
    other = distributed.Client(client.scheduler.address)

    def close_after_the_first_rows():
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not got:
            time.sleep(0.01)
        other.close()

    closer = threading.Thread(target=close_after_the_first_rows)
    closer.start()
    try:
        with pytest.raises(ClusterError, match=r"^the Dask client was closed mid-run; the rows scored before are kept"):
            evaluate(SlowNearest(0.3), streets, seeds=[0, 1], batch_size=2, progress=False, client=other,
                     on_batch=got.append)
    finally:
        closer.join()
        other.close()
    assert got


def test_no_finished_shard_within_the_timeout_is_an_error(client, streets, monkeypatch):
    monkeypatch.setattr(cluster, "SHARD_TIMEOUT", 0.5)
    with pytest.raises(ClusterError, match=r"no shard finished within 0\.5 s|no shard finished within 0 s"):
        evaluate(SlowNearest(2.0), streets, n_frames=2, progress=False, client=client)


def test_unpicklable_method_is_refused_before_submitting(client, streets):
    class Locked:
        lock = None

        def __init__(self):
            self.lock = threading.Lock()

        def __call__(self, x):
            return np.nan_to_num(x)

    with pytest.raises(TypeError, match="method Locked cannot be sent to Dask workers"):
        evaluate(Locked(), streets, progress=False, client=client)


def test_a_cluster_is_not_a_client(client, streets):
    with pytest.raises(TypeError, match=r"wrap it: Client\(cluster\)"):
        evaluate(NearestInpainter(), streets, progress=False, client=client.cluster)


@pytest.mark.parametrize("spec", ["local:0", "local:x", "localhost:8786", "8786", ""])
def test_bad_scheduler_values(spec):
    with pytest.raises(ValueError, match="--scheduler takes tcp://HOST:PORT or local:N"):
        parse_scheduler(spec)


def test_scheduler_values():
    assert parse_scheduler("local:3") == ("local", 3)
    assert parse_scheduler("tcp://10.0.0.5:8786") == ("address", "tcp://10.0.0.5:8786")


def test_unreachable_scheduler_is_one_line():
    with pytest.raises(ClusterError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"), \
            open_client("tcp://127.0.0.1:9", timeout=1):
        pass


def test_without_dask_the_error_names_the_extra(monkeypatch, capsys):
    for name in [m for m in sys.modules if m == "distributed" or m.startswith("distributed.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    rc = main(["evaluate", "-m", "constant", "--n-frames", "2", "--frame-shape", *map(str, SHAPE), "-q",
               "--scheduler", "local:2"])
    err = capsys.readouterr().err.strip()
    assert rc == 1 and len(err.splitlines()) == 1
    assert 'pip install "inpaintenv[dask]"' in err and "--scheduler" in err


def test_inpaintenv_imports_without_dask():
    import subprocess

    code = (
        "import sys; sys.modules['distributed'] = None; sys.modules['dask'] = None\n"
        "import inpaintenv, inpaintenv.cli, inpaintenv.evaluate, inpaintenv.benchmark, inpaintenv.cluster\n"
        "print('ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


@pytest.mark.slow
def test_scaling_doc_examples_run(tmp_path, monkeypatch, capsys):
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "scaling.md").read_text()
    code = "\n".join(re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL))
    monkeypatch.chdir(tmp_path)
    # Run as a script would: the Dask example guards its cluster with __name__ == "__main__".
    exec(compile(code.replace("/tmp/", f"{tmp_path}/"), "docs/scaling.md", "exec"), {"__name__": "__main__"})  # noqa: S102
    out = capsys.readouterr().out
    assert out.count("| ScanlineInpainter | rect-v1 |") == 1 and "| TeleaInpainter | rect-v1 |" in out
    assert (tmp_path / "scaling-example" / "rows" / "scanline__rect-v1.jsonl").exists()


class NearestWithBand:
    """Nearest fill with the interval fill ± 2 m, for intervals scored on workers."""

    def predict(self, x: np.ndarray) -> np.ndarray:
        return NearestInpainter(n_jobs=1).predict(x)

    def predict_interval(self, x: np.ndarray, coverage: float = 0.9):
        p = self.predict(x)
        return np.maximum(p - 2.0, 0.0), p + 2.0


def test_intervals_on_cluster_give_the_serial_rows(client, streets):
    kw = {"seeds": [0], "batch_size": 4, "progress": False, "intervals": 0.9}
    dist = evaluate(NearestWithBand(), streets, client=client, **kw)
    serial = evaluate(NearestWithBand(), streets, **kw)
    assert "hole_coverage" in serial.rows[0]
    assert without_ms(dist.rows) == without_ms(serial.rows)
    assert dist.meta == serial.meta


class OtherIdsOnWorkers(SyntheticStreets):
    """Synthetic streets whose copy on a worker names its frames otherwise: a worker that reads
    other data than the client planned (another version of a file list)."""

    def __setstate__(self, state):
        self.__dict__.update(state)
        self.frame_ids = [f"elsewhere/{i}" for i in range(len(self.frame_ids))]


@pytest.fixture(scope="module")
def small_run(client, tmp_path_factory):
    out = tmp_path_factory.mktemp("dask-run") / "run"
    source = SyntheticStreets(n=3, frame_shape=SHAPE)
    run_benchmark({"harmonic": NearestInpainter(n_jobs=1)}, source, protocols=["rect-v1"], out_dir=out,
                  client=client, progress=False)
    return out, source


@pytest.mark.parametrize("name", sorted(HOSTILE_ROWS))
def test_dask_resume_refuses_a_row_its_run_could_not_have_written(name, client, small_run, tmp_path):
    edit, says = HOSTILE_ROWS[name]
    out = tmp_path / "run"
    shutil.copytree(small_run[0], out)
    path = out / "rows" / "harmonic__rect-v1.jsonl"
    tamper_rows(path, edit)
    before = path.read_bytes()
    with pytest.raises(RunStateError, match=rf"line \d+ of .*harmonic__rect-v1\.jsonl is not a row of this run: "
                                            rf".*{says}"):
        run_benchmark({"harmonic": NearestInpainter(n_jobs=1)}, small_run[1], protocols=["rect-v1"], out_dir=out,
                      client=client, progress=False)
    assert path.read_bytes() == before


def test_rows_a_worker_sends_back_are_checked_before_they_are_kept(client, tmp_path):
    source = OtherIdsOnWorkers(n=3, frame_shape=SHAPE)
    with pytest.raises(ResultRowError, match=r"a Dask worker sent back a row .*frame_id 'elsewhere/0' is not frame 0's"):
        run_benchmark({"nearest": NearestInpainter(n_jobs=1)}, source, protocols=["rect-v1"],
                      out_dir=tmp_path / "run", client=client, progress=False)
    assert not list((tmp_path / "run" / "rows").glob("*.jsonl"))  # nothing of it written
