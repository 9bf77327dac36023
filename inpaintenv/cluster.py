"""Score shards of frames on a Dask cluster and stream their results back.

Past one machine, :func:`inpaintenv.evaluate.evaluate` (``client=``) and the benchmark
runner (``run_benchmark(..., client=)``, ``inpaintenv benchmark --scheduler``) hand
shards of frame indices to Dask workers. Each worker loads its frames itself from the
data source (which therefore must pickle, as ``KittiDepth`` and ``SyntheticStreets`` do:
as file lists or generator parameters, never pixels) and returns the shard's rows; the
client receives them as shards finish, so the run folder fills as in a serial run.

Dask (``distributed``) is an optional extra, ``pip install "inpaintenv[dask]"``: it is
imported only when a client or ``--scheduler`` is used.

Example
-------
>>> from dask.distributed import Client, LocalCluster          # doctest: +SKIP
>>> with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
...     result = evaluate(method, source, seeds=[0, 1], client=client)   # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import logging
import os
import pickle
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import CancelledError
from contextlib import contextmanager, suppress
from typing import Any

from .exceptions import ClusterError, InvalidInputError, InvalidTypeError, MissingDependencyError, WorkerDataError

__all__ = [
    "ClusterError", "WorkerDataError", "add_scheduler_option", "check_client", "map_shards",
    "open_client", "parse_scheduler", "quiet_dask_logs",
]

#: Seconds to wait for the scheduler to answer, or for a first worker to join it.
CONNECT_TIMEOUT = 30.0
#: Seconds without any shard finishing before a run is declared stuck (a hung worker,
#: a frozen network mount); far above the slowest method's shard on a CPU.
SHARD_TIMEOUT = 600.0
#: Times Dask reruns a shard whose task raised (a transient read error); a worker that
#: dies is handled by Dask itself (``distributed.scheduler.allowed-failures``).
RETRIES = 1
#: Dask's configuration of the environment of worker processes started by a nanny.
PRE_SPAWN_ENVIRON = "distributed.nanny.pre-spawn-environ"
#: Dask's default MALLOC_TRIM_THRESHOLD_ for workers (bytes), unset by ``local:N``.
DASK_MALLOC_TRIM = 65536
_EXTRA_HINT = 'Dask is not installed: pip install "inpaintenv[dask]"'
#: Loggers silenced while a run uses the cluster (below CRITICAL): a lost scheduler made
#: them print tracebacks before the run's own one-line error.
NOISY_LOGGERS = ("distributed", "tornado")
#: Set to keep Dask's own log lines (and tracebacks) during a run, e.g. to debug a cluster.
TRACEBACK_ENV = "INPAINTENV_TRACEBACK"


# ---------------------------------------------------------------------------------------
# Connecting
# ---------------------------------------------------------------------------------------
@contextmanager
def quiet_dask_logs() -> Iterator[None]:
    """Silence ``distributed``'s and ``tornado``'s log records below CRITICAL for the block.

    Every failure of a run reaches the user as one line (:class:`ClusterError`); Dask's
    own records of it (a lost connection's tracebacks) would come first. With
    ``INPAINTENV_TRACEBACK`` set, nothing is silenced. Nested uses restore the levels
    they found.
    """
    if os.environ.get(TRACEBACK_ENV):
        yield
        return
    manager = logging.Logger.manager
    names = [n for n in list(manager.loggerDict) if n.split(".")[0] in NOISY_LOGGERS]
    loggers = [logging.getLogger(n) for n in dict.fromkeys([*NOISY_LOGGERS, *names])]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)

def _distributed(what: str = "a Dask client") -> Any:
    """The ``distributed`` module, or an ImportError naming the extra to install."""
    try:
        import distributed
    except ImportError:
        raise MissingDependencyError(f"{what} needs Dask's distributed scheduler. {_EXTRA_HINT}") from None
    return distributed


def add_scheduler_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--scheduler`` (shared by ``inpaintenv evaluate`` and ``inpaintenv benchmark``)."""
    parser.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="score on a Dask cluster: tcp://HOST:PORT of a running scheduler, or local:N for "
             'N worker processes on this machine (needs pip install "inpaintenv[dask]")',
    )


def parse_scheduler(spec: str) -> tuple[str, Any]:
    """Read a ``--scheduler`` value: ``("local", n_workers)`` or ``("address", address)``.

    Raises
    ------
    ValueError
        If ``spec`` is neither ``local:N`` (N >= 1) nor a ``scheme://host:port`` address.
    """
    match = re.fullmatch(r"local:(\d+)", spec.strip())
    if match:
        n = int(match.group(1))
        if n >= 1:
            return "local", n
    elif re.fullmatch(r"[a-z]+://\S+", spec.strip()):
        return "address", spec.strip()
    raise InvalidInputError(f"--scheduler takes tcp://HOST:PORT or local:N (N >= 1 worker processes), got {spec!r}")


@contextmanager
def open_client(scheduler: str | None, *, timeout: float = CONNECT_TIMEOUT) -> Iterator[Any]:
    """A Dask client for a ``--scheduler`` value, closed (with its local cluster) on exit.

    Parameters
    ----------
    scheduler : str or None
        ``tcp://HOST:PORT`` (any scheme Dask knows) connects to a running scheduler;
        ``local:N`` starts a ``LocalCluster`` of N single-threaded worker processes
        listening on 127.0.0.1 only; None yields None (run in this process).
    timeout : float
        Seconds to wait for a remote scheduler to answer.

    Raises
    ------
    ImportError
        If Dask is not installed (the message names the extra).
    ClusterError
        If the scheduler cannot be reached, or the local workers cannot start.
    ValueError
        If ``scheduler`` is neither form (see :func:`parse_scheduler`).
    """
    if scheduler is None:
        yield None
        return
    kind, value = parse_scheduler(scheduler)
    dd = _distributed("--scheduler")
    with quiet_dask_logs():
        yield from _clients(dd, kind, value, timeout)


def _clients(dd: Any, kind: str, value: Any, timeout: float) -> Iterator[Any]:
    """The body of :func:`open_client`: one client, closed (with its local cluster) on exit."""
    if kind == "local":
        import dask

        # Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 in workers, which makes glibc
        # unmap and re-fault every frame-sized array: evaluate() ran ~2x slower
        # (perf/bench_dask.py --malloc-check). Unset it, also where an earlier nanny
        # left it in this process's environment (nannies write it there, and a variable
        # set here overrides Dask's configuration).
        if os.environ.get("MALLOC_TRIM_THRESHOLD_") == str(DASK_MALLOC_TRIM):
            del os.environ["MALLOC_TRIM_THRESHOLD_"]
        try:
            # Loopback only, dashboard included: a local run opens no port to the network.
            with dask.config.set({f"{PRE_SPAWN_ENVIRON}.MALLOC_TRIM_THRESHOLD_": None}):
                cluster = dd.LocalCluster(
                    n_workers=value, threads_per_worker=1, processes=True, host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",
                )
        except (OSError, RuntimeError, TimeoutError) as exc:
            raise ClusterError(f"cannot start {value} local Dask workers: {_one_line(exc)}") from None
        with cluster, dd.Client(cluster) as client:
            yield client
        return
    try:
        client = dd.Client(value, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        raise ClusterError(f"cannot reach the Dask scheduler at {value}: {_one_line(exc)}") from None
    with client:
        yield client


def check_client(client: Any) -> Any:
    """``client`` if it is a ``distributed.Client``, else a TypeError saying what to pass."""
    dd = _distributed("client=")
    if not isinstance(client, dd.Client):
        hint = " (wrap it: Client(cluster))" if isinstance(client, dd.deploy.Cluster) else ""
        raise InvalidTypeError(f"client must be a dask.distributed.Client, got {type(client).__name__}{hint}")
    return client


# ---------------------------------------------------------------------------------------
# Running shards
# ---------------------------------------------------------------------------------------
def map_shards(
    client: Any,
    fn: Callable[..., Any],
    shards: Sequence[Any],
    *,
    shared: Mapping[str, Any],
    on_result: Callable[[Any], None] | None = None,
) -> list[Any]:
    """Run ``fn(shard, **shared)`` for every shard on the client's workers.

    ``shared`` values (the method, the data source) are sent to the cluster once, as
    tasks Dask can recompute if the worker holding them dies, not once per shard.
    ``on_result`` receives each shard's result on the client as soon as it finishes
    (completion order); the return value lists them in shard order.

    Raises
    ------
    WorkerDataError
        If a worker cannot read the data (names the worker and the file).
    ClusterError
        If no worker is connected, a shard's workers keep dying, no shard finishes
        within :data:`SHARD_TIMEOUT` seconds, or the scheduler or this client is lost
        mid-run (results already passed to ``on_result`` stand).
    TypeError
        If a shared value cannot be pickled (it could not reach the workers).
    Exception
        Whatever ``fn`` raised on a worker (e.g. ``MethodOutputError``); the remaining
        shards are cancelled first.
    """
    dd = _distributed()
    check_client(client)
    for key, value in shared.items():
        _check_picklable(value, key)
    with quiet_dask_logs():
        return _map_shards(dd, client, fn, shards, shared, on_result)


def _map_shards(dd: Any, client: Any, fn: Callable[..., Any], shards: Sequence[Any], shared: Mapping[str, Any],
                on_result: Callable[[Any], None] | None) -> list[Any]:
    """The body of :func:`map_shards`, with Dask's log records silenced."""
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except TimeoutError:
        raise ClusterError(
            f"no Dask worker joined the scheduler at {client.scheduler.address} within {CONNECT_TIMEOUT:.0f} s"
        ) from None
    # Tasks, not scatter: Dask recomputes a task's result lost with a worker; scattered
    # data would be gone.
    shared_futures = {k: client.submit(_identity, v, pure=False) for k, v in shared.items()}
    futures = [
        client.submit(_run_shard, fn, shard, shared_futures, pure=False, retries=RETRIES) for shard in shards
    ]
    position = {f.key: k for k, f in enumerate(futures)}
    results: list[Any] = [None] * len(futures)
    pending = set(futures)
    address = client.scheduler.address
    try:
        while pending:
            try:
                done, pending = dd.wait(pending, timeout=SHARD_TIMEOUT, return_when="FIRST_COMPLETED")
            except TimeoutError:
                raise ClusterError(
                    f"no shard finished within {SHARD_TIMEOUT:.0f} s ({len(pending)} pending on "
                    f"{len(client.nthreads())} workers); a worker may be stuck reading the data"
                ) from None
            for future in done:
                result = _result(dd, future, client, address)
                results[position[future.key]] = result
                future.release()
                if on_result is not None:
                    on_result(result)
    except (CancelledError, dd.client.ClosedClientError, dd.comm.CommClosedError):
        # The scheduler died or this client was closed: every pending future is cancelled
        # at once (FuturesCancelledError, "scheduler-connection-lost"). Results already
        # handed to on_result (a benchmark's row files) stay valid.
        raise ClusterError(_lost_message(client, address)) from None
    except RuntimeError:
        # Closing the client while a result is awaited can also fail inside asyncio ("... is
        # bound to a different event loop"): the same lost run. With the client still running
        # the error is the method's own and goes up unchanged.
        if client.status == "running":
            raise
        raise ClusterError(_lost_message(client, address)) from None
    finally:
        # An error, Ctrl-C or a finished run: nothing of this run stays on the cluster. A
        # closed or disconnected client cannot cancel, and must not hide the cause.
        _cancel_quietly(client, list(pending) + list(shared_futures.values()))
    return results


def _lost_message(client: Any, address: str) -> str:
    """One line for a run that lost its scheduler or client mid-run."""
    what = (
        "the Dask client was closed" if client.status in ("closing", "closed")
        else f"the connection to the Dask scheduler at {address} was lost"
    )
    return (
        f"{what} mid-run; the rows scored before are kept (a benchmark's run folder resumes: rerun the same "
        "command once the scheduler is back)"
    )


def _cancel_quietly(client: Any, futures: list[Any]) -> None:
    """Cancel ``futures`` if the client can still reach its scheduler."""
    if not futures or client.status != "running":
        return
    with suppress(Exception):  # lost in the meantime: nothing left to cancel on
        client.cancel(futures)


def _result(dd: Any, future: Any, client: Any, address: str) -> Any:
    """A finished shard's result; cluster failures become one-line ClusterErrors."""
    try:
        return future.result()
    except dd.KilledWorker as exc:
        last = getattr(getattr(exc, "last_worker", None), "address", "?")
        failures = getattr(exc, "allowed_failures", "?")
        raise ClusterError(
            f"a shard's workers died {failures} times running it (last: {last}); "
            "see the worker logs (memory? a crashing method?)"
        ) from None
    except (CancelledError, dd.client.ClosedClientError, dd.comm.CommClosedError):
        if client.status != "running":  # a closed client or a lost scheduler: say which
            raise ClusterError(_lost_message(client, address)) from None
        raise ClusterError("a shard was cancelled: the scheduler lost it or this client was disconnected") from None


def _identity(value: Any) -> Any:
    return value


def _run_shard(fn: Callable[..., Any], shard: Any, shared: Mapping[str, Any]) -> Any:
    """Worker side: run one shard; a failed read names this worker and the path."""
    try:
        return fn(shard, **shared)
    except Exception as exc:
        cause = _os_error_in(exc)
        if cause is None:
            raise
        raise WorkerDataError(f"worker {_worker_address()} cannot read the data: {_one_line(cause)}") from exc


def _os_error_in(exc: BaseException) -> OSError | None:
    """The OSError behind ``exc`` (itself or what it was raised from), if any."""
    seen = 0
    current: BaseException | None = exc
    while current is not None and seen < 8:
        if isinstance(current, OSError) and not isinstance(current, WorkerDataError):
            return current
        current = current.__cause__ or current.__context__
        seen += 1
    return None


def _worker_address() -> str:
    try:
        return _distributed().get_worker().address
    except ValueError:  # not running on a worker (e.g. called directly)
        return "<not a worker>"


def _check_picklable(value: Any, what: str) -> None:
    import cloudpickle  # a dependency of distributed

    try:
        cloudpickle.dumps(value)
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        raise InvalidTypeError(
            f"the {what} {type(value).__name__} cannot be sent to Dask workers (it does not pickle: "
            f"{_one_line(exc)}); open files, locks and live connections must be opened on the worker"
        ) from None


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]
