"""Where a study's tasks run: in this process one after another, or as Dask tasks.

``open_engine(workers, address)`` gives an engine whose ``run(fn, tasks, done, describe)`` calls ``fn(*task)``
for every task and ``done(k, value)`` in this process as each finishes (in any order; ``describe(k)`` names
task k in messages):

* ``workers == 0`` (and no address): ``Serial``, in this process, in order;
* otherwise ``Dask``: on an existing cluster at ``address`` (``tcp://host:port``: ``scheduler_address`` reads
  ``--scheduler`` or the environment variable ``SHELLCONTACT_SCHEDULER``), else on an embedded
  ``LocalCluster`` of ``workers`` processes (None: one per core) with one thread each and one BLAS thread
  (Dask's ``distributed.nanny.pre-spawn-environ``).

Network exposure: everything the embedded cluster opens (scheduler, workers, nannies, dashboard) listens on
127.0.0.1 only. An external scheduler is reached at ``tcp://`` or, with Dask's TLS settings
(``distributed.comm.tls.*``, e.g. ``DASK_DISTRIBUTED__COMM__TLS__CA_FILE``), ``tls://``; Dask's own security
configuration is used as it is. Connecting, and the first answer, time out after ``CONNECT_TIMEOUT``; a
scheduler without a worker is waited for ``WORKER_TIMEOUT``, then refused with what to start.

A task lost with a killed worker is run again on another (Dask's ``distributed.scheduler.allowed-failures``).
On an error or an interruption the tasks are cancelled and an embedded cluster's workers are killed at once
(a graceful close would wait for the running tasks). Dask is imported only here, when an engine is opened.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import secrets
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..errors import InputError

SCHEDULER_ENV = "SHELLCONTACT_SCHEDULER"
ONE_THREAD = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}
log = logging.getLogger("shellcontact")

Done = Callable[[int, Any], None]
#: seconds: to connect to an external scheduler and hear its first answer; to wait for its first worker
CONNECT_TIMEOUT, WORKER_TIMEOUT = 20.0, 60.0
LOOPBACK = "127.0.0.1"
_ADDRESS = re.compile(r"(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)"
                      r"(?::(?P<port>[0-9]{1,5}))?")


def max_workers() -> int:
    """The most worker processes of an embedded cluster (or sweep jobs): four per core."""
    return 4 * (os.cpu_count() or 1)


def tls_configured() -> bool:
    """Whether Dask's configuration names a CA file and a client certificate (``distributed.comm.tls``)."""
    import dask

    return bool(dask.config.get("distributed.comm.tls.ca-file", None)
                and dask.config.get("distributed.comm.tls.client.cert", None))


def check_address(address: str, where: str) -> str:
    """``tcp://host:port``, or ``tls://host:port`` with Dask's TLS settings; anything else is an InputError."""
    usage = "a Dask scheduler address such as tcp://host:8786"
    m = _ADDRESS.fullmatch(address)
    if m is None:
        what = "it has spaces in it" if address != "".join(address.split()) else f"expected {usage}"
        raise InputError(where, f"{what}, got {address!r}")
    scheme = m["scheme"]  # as Dask spells it: lower case
    if scheme not in ("tcp", "tls"):
        raise InputError(where, f"the scheme {m['scheme']}:// is not supported: use tcp://host:port, or "
                         f"tls://host:port with Dask's TLS settings (docs/studies.md), got {address!r}")
    if m["port"] is None or not 0 < int(m["port"]) < 65536:
        raise InputError(where, f"needs a port from 1 to 65535 (the scheduler's, usually 8786), e.g. "
                         f"{scheme}://{m['host']}:8786, got {address!r}")
    if scheme == "tls" and not tls_configured():
        raise InputError(where, "tls:// needs Dask's TLS settings: a CA file and a client certificate and key, e.g. "
                         "DASK_DISTRIBUTED__COMM__TLS__CA_FILE, DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT and "
                         "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY (docs/studies.md)")
    return address


def scheduler_address(scheduler: str | None) -> str | None:
    """``--scheduler``, else ``SHELLCONTACT_SCHEDULER``, else None (an embedded cluster); checked."""
    address = scheduler if scheduler is not None else os.environ.get(SCHEDULER_ENV) or None
    if address is not None:
        check_address(address, "--scheduler" if scheduler is not None else SCHEDULER_ENV)
    return address


class Serial:
    """Every task in this process, in order."""

    workers = 1
    description = "in this process"
    dashboard: str | None = None

    def run(self, fn: Callable[..., Any], tasks: Sequence[tuple], done: Done,
            describe: Callable[[int], str] = lambda k: f"task {k}") -> None:
        for k, args in enumerate(tasks):
            done(k, fn(*args))

    def close(self, abort: bool = False) -> None:
        pass


class Dask:
    """A Dask client on an existing scheduler or on an embedded ``LocalCluster``."""

    def __init__(self, workers: int | None, address: str | None, option: str = "--scheduler",
                 notice: Callable[[str], None] | None = None) -> None:
        self.cluster = self.client = None
        self.notice = notice or log.info
        try:
            self._start(workers, address, option)
        except BaseException:  # e.g. Ctrl-C while the workers start: none is left behind
            self.close(abort=True)
            raise

    def _start(self, workers: int | None, address: str | None, option: str) -> None:
        import distributed

        if address is None:
            import dask

            n = (os.cpu_count() or 1) if workers is None else workers
            # one BLAS thread per worker process, set before it starts (whatever the user's Dask config says)
            environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}), **ONE_THREAD}
            with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
                # silence_logs: a failed task is raised here (its own error), not also logged by its worker
                # loopback only, the dashboard too (":0" alone would listen on every interface); a free port:
                # several studies at once
                self.cluster = _start_quietly(lambda: distributed.LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, silence_logs=logging.CRITICAL,
                    host=LOOPBACK, dashboard_address=f"{LOOPBACK}:0", worker_dashboard_address=None))
            self.client = distributed.Client(self.cluster)
            self.description = f"an embedded Dask cluster of {n} worker process{'es' * (n != 1)}"
        else:
            self.client = _connect(address, option)
            self.description = f"the Dask cluster at {address}"
        info = self.client.scheduler_info()
        self.workers = len(info.get("workers", {}))
        if address is not None and self.workers == 0:
            self.notice(f"the Dask scheduler at {address} has no worker yet; waiting up to {WORKER_TIMEOUT:g} s "
                        "for one")
            try:
                self.client.wait_for_workers(1, timeout=WORKER_TIMEOUT)
            except (TimeoutError, OSError):
                raise InputError(option, f"the Dask scheduler at {address} has no worker (waited {WORKER_TIMEOUT:g} "
                                 f"s): start one with `dask worker {address}`, or drop {option} to use an "
                                 "embedded cluster") from None
            self.workers = len(self.client.scheduler_info().get("workers", {}))
        self.workers = max(1, self.workers)
        if address is not None:
            self.description += f" ({self.workers} worker{'s' * (self.workers != 1)} now)"
        self.dashboard = None
        if "dashboard" in info.get("services", {}):
            self.dashboard = self.client.dashboard_link
            if address is None and not _has_dashboard():  # the scheduler serves its plain pages only
                from urllib.parse import urlsplit

                link = urlsplit(self.dashboard)
                self.dashboard = (f"{link.scheme}://{link.netloc}/info/main/workers.html (the full dashboard "
                                  "needs bokeh: pip install bokeh)")

    def run(self, fn: Callable[..., Any], tasks: Sequence[tuple], done: Done,
            describe: Callable[[int], str] = lambda k: f"task {k}") -> None:
        from distributed import KilledWorker, as_completed

        token = secrets.token_hex(4)
        futures = [self.client.submit(fn, *args, key=f"shellcontact-{token}-{k}", pure=False)
                   for k, args in enumerate(tasks)]
        index = {f.key: k for k, f in enumerate(futures)}
        try:
            for fut in as_completed(futures):
                try:
                    value = fut.result()
                except KilledWorker as exc:  # after distributed.scheduler.allowed-failures workers died with it
                    raise InputError("--workers", f"{describe(index[fut.key])} ended every worker that ran it ({exc}); "
                                     "most often a worker out of memory: give each more (fewer per machine) or "
                                     "use a coarser mesh") from None
                done(index[fut.key], value)
        except BaseException:
            self.client.cancel(futures, force=True)
            raise

    def close(self, abort: bool = False) -> None:
        with _silenced(abort):
            self._close(abort)
        if abort and self.cluster is not None:  # Dask's exit hook must not close it again (and print why not)
            from distributed.deploy.spec import SpecCluster

            SpecCluster._instances.discard(self.cluster)

    def _close(self, abort: bool) -> None:
        if abort and self.cluster is not None:
            for nanny in list(self.cluster.workers.values()):  # kill the running tasks now
                pid = getattr(getattr(nanny, "process", None), "pid", None)
                if pid:
                    try:
                        os.kill(pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
        timeout = 0.5 if abort else 20  # aborted: the workers are dead already; nothing to wait for
        for part in (self.client, self.cluster):
            if part is not None:
                try:
                    part.close(timeout=timeout)
                except Exception as exc:  # noqa: BLE001 — closing after the work is done or abandoned
                    log.debug("closing %s: %s", type(part).__name__, exc)


#: the loggers that report the tasks an abort leaves unfinished
NOISY = ("distributed", "asyncio", "tornado")


@contextlib.contextmanager
def _silenced(silence: bool = True) -> Iterator[None]:
    """Dask's, asyncio's and tornado's logs off (an abort's unfinished tasks are not news)."""
    if not silence:
        yield
        return
    loggers = [logging.getLogger(name) for name in NOISY]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def silence_dask() -> None:
    """Dask's logs off for the rest of the process (the command line, ending after an interruption)."""
    for name in NOISY:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


_LAUNCHERS: set[str] = set()  # the spawn executables this module sets (its launchers, and "no spawn")
_REAL_EXECUTABLE: list[str] = []  # multiprocessing's own executable, before any of ours
ABANDON_TIMEOUT = 30.0  # s: an interrupted cluster start is waited for this long (its workers exit at once)
RESTORE_DELAY = 2.0  # s after an abandoned start before new processes may spawn Python again


def _real_spawn_executable() -> str | None:
    import multiprocessing.spawn

    current = multiprocessing.spawn.get_executable()
    if current is not None and os.fsdecode(current) not in _LAUNCHERS:
        _REAL_EXECUTABLE[:] = [os.fsdecode(current)]
    return _REAL_EXECUTABLE[0] if _REAL_EXECUTABLE else None


@contextlib.contextmanager
def _workers_ignore_sigint() -> Iterator[Callable[[], None]]:
    """Worker processes spawned inside start with SIGINT ignored: Python is launched through ``/bin/sh`` after
    ``trap '' INT`` (an ignored signal stays ignored across exec, and Python then installs no KeyboardInterrupt
    handler). A terminal's Ctrl-C reaches the whole process group; this process ends the workers itself.
    Yields ``abandon``: from then on a spawned process runs ``false`` and exits at once (an abandoned start, or a
    nanny restarting a killed worker, may still spawn; such a worker would unpickle locks this process has
    released, or outlive it), and Python is spawned again only ``RESTORE_DELAY`` s after the abandoned start."""
    import multiprocessing.spawn
    import shlex
    import shutil
    import tempfile

    real = _real_spawn_executable()
    no_spawn = shutil.which("false")
    if not os.path.exists("/bin/sh") or real is None or no_spawn is None:
        yield lambda: None
        return
    directory = tempfile.mkdtemp(prefix="shellcontact-launch-")
    launcher = os.path.join(directory, "python")
    _LAUNCHERS.update((launcher, no_spawn))
    abandoned = threading.Event()

    def abandon() -> None:
        abandoned.set()
        multiprocessing.spawn.set_executable(no_spawn)

    try:
        with open(launcher, "w") as fh:
            fh.write(f"#!/bin/sh\ntrap '' INT\nexec {shlex.quote(real)} \"$@\"\n")
        os.chmod(launcher, 0o700)
        multiprocessing.spawn.set_executable(launcher)
        yield abandon
    finally:
        if abandoned.is_set():
            threading.Thread(target=_restore_spawning, args=(no_spawn, real), daemon=True,
                             name="shellcontact-restore-spawn").start()
        else:
            multiprocessing.spawn.set_executable(real)
        with contextlib.suppress(OSError):
            os.unlink(launcher)
            os.rmdir(directory)


def _restore_spawning(no_spawn: str, real: str) -> None:
    import multiprocessing.spawn
    import time

    time.sleep(RESTORE_DELAY)
    if os.fsdecode(multiprocessing.spawn.get_executable()) == no_spawn:  # unless a new start has set its own
        multiprocessing.spawn.set_executable(real)


def _start_resource_tracker() -> None:
    """multiprocessing's resource tracker, started without its shutdown warnings about semaphores (it still
    removes them): a Dask thread interrupted between unlinking a lock and telling the tracker, as the process
    ends after a Ctrl-C, makes it warn of a leak that is not one and of a file already gone."""
    from multiprocessing import resource_tracker

    key = "PYTHONWARNINGS"
    previous = os.environ.get(key)
    os.environ[key] = ",".join(filter(None, [previous, "ignore:resource_tracker:UserWarning"]))
    try:
        resource_tracker.ensure_running()
    finally:
        if previous is None:
            del os.environ[key]
        else:
            os.environ[key] = previous


def _start_quietly(start: Callable[[], Any]) -> Any:
    """``start()`` (a LocalCluster) in a thread, its workers ignoring SIGINT, while this thread waits: a Ctrl-C
    then kills the workers started so far and abandons the start, without a traceback from Dask or from a
    worker; the abandoned clusters are removed from Dask's exit hook."""
    import psutil
    from distributed.deploy.spec import SpecCluster

    box: dict[str, Any] = {}
    before = set(SpecCluster._instances)
    _start_resource_tracker()  # a process of its own, started before the snapshot: never killed here
    children = {p.pid for p in psutil.Process().children(recursive=True)}

    def run() -> None:
        try:
            box["value"] = start()
        except BaseException as exc:  # noqa: BLE001 — handed to the waiting thread
            box["error"] = exc

    def kill_new_children() -> None:
        for child in psutil.Process().children(recursive=True):
            if child.pid not in children:
                with contextlib.suppress(psutil.Error):
                    child.kill()

    thread = threading.Thread(target=run, name="shellcontact-cluster", daemon=True)
    with _workers_ignore_sigint() as abandon:
        try:
            thread.start()
            while thread.is_alive():
                thread.join(0.05)
        except BaseException:
            with contextlib.suppress(KeyboardInterrupt):  # a second Ctrl-C does not stop the clean-up
                abandon()
                silence_dask()
                kill_new_children()
                thread.join(ABANDON_TIMEOUT)
                kill_new_children()  # those spawned before the start gave up
            for cluster in set(SpecCluster._instances) - before:
                SpecCluster._instances.discard(cluster)
            raise
    if "error" in box:
        raise box["error"]
    return box["value"]


def _connect(address: str, option: str) -> Any:
    """A Dask client of the scheduler at ``address`` within ``CONNECT_TIMEOUT`` seconds, however it answers:
    a port that accepts and never answers, or answers something else (a web server's bytes), is refused."""
    import distributed

    box: dict[str, Any] = {}

    def connect() -> None:
        try:
            box["client"] = distributed.Client(address, timeout=f"{CONNECT_TIMEOUT}s")
        except BaseException as exc:  # noqa: BLE001 — handed to the waiting thread
            box["error"] = exc

    worker = threading.Thread(target=connect, name="shellcontact-connect", daemon=True)
    worker.start()
    worker.join(CONNECT_TIMEOUT + 5)  # Dask's own timeout does not cover every handshake
    if worker.is_alive():
        raise InputError(option, f"the Dask scheduler at {address} did not answer within {CONNECT_TIMEOUT:g} s; "
                         "check the address and port (the scheduler's, usually 8786, not the dashboard's)")
    exc = box.get("error")
    if isinstance(exc, (OSError, TimeoutError)):
        raise InputError(option, f"cannot reach the Dask scheduler at {address}: {exc}") from None
    if isinstance(exc, (MemoryError, ValueError, TypeError, EOFError)) or (exc is not None and
                                                                          type(exc).__module__.startswith("distributed")):
        raise InputError(option, f"{address} did not answer as a Dask scheduler ({type(exc).__name__}); check the "
                         "address and port (the scheduler's, usually 8786, not the dashboard's)") from None
    if exc is not None:
        raise exc
    return box["client"]


def _has_dashboard() -> bool:
    """The dashboard needs bokeh (``pip install bokeh``)."""
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


class open_engine:  # noqa: N801 — used as a context manager, like open()
    """``with open_engine(workers, address) as engine: engine.run(...)``; an exception aborts the engine.
    ``option``: what gave the address (named when the scheduler cannot be reached)."""

    def __init__(self, workers: int | None, address: str | None, option: str = "--scheduler",
                 notice: Callable[[str], None] | None = None) -> None:
        self.workers = workers
        self.address = address
        self.option = option
        self.notice = notice
        self.engine: Serial | Dask | None = None

    def __enter__(self) -> Serial | Dask:
        if self.workers == 0 and self.address is None:
            self.engine = Serial()
        else:
            self.engine = Dask(self.workers, self.address, self.option, self.notice)
        return self.engine

    def __exit__(self, kind, exc, tb) -> None:
        if self.engine is not None:
            self.engine.close(abort=kind is not None)
