"""One model on several MPI processes: rank 0 (the host) does everything, the other ranks serve MUMPS.

Under ``mpiexec -n N shellcontact ...`` (or ``run_on_host(fn)`` in a script started by mpiexec), rank 0
reads the case, meshes, assembles, runs the contact loop and writes the outputs, exactly as one process
does; the factorisations and solves of the ``mumps`` backend are MUMPS calls on all N ranks (MUMPS
distributes the factors and the work). Ranks 1..N−1 run ``serve``: they wait for rank 0's commands
(create an instance, run a JOB, free it, report memory, exit) and make the matching MUMPS call, so that
every collective call has all ranks in it. They exit when rank 0 says so (``release``), which it does
when it finishes or fails; a rank 0 killed by a signal makes mpiexec end the others.

mpi4py is imported only when MPI is used (the ``mumps`` backend, or a launch by mpiexec): a plain run
never initialises MPI.
"""

from __future__ import annotations

import os
import resource
import sys
import time
from collections.abc import Callable
from typing import Any

from ..launcher import launched_ranks
from .mumps_c import Instance

_TAG = 2727
#: how long a waiting rank sleeps between looks for a command: Open MPI's blocking receive spins a core,
#: which on a machine with as many ranks as cores would take one from rank 0's serial work
_POLL_SECONDS = 0.0005


#: a process that no launcher started (the mumps backend in a plain run) is MPI's only rank: it needs no TCP
#: transport and no helper daemon, so nothing listens (the user's own settings win). Open MPI 4 would otherwise
#: fork ``orted``, whose PMIx server listens on every interface (0.0.0.0 and ::, whatever oob_tcp_if_include or
#: PMIx's ptl_tcp/ptl_base if_include say: measured with Open MPI 4.1.4, PMIx 4.2.2); ess_singleton_isolated
#: starts none (the process then cannot spawn others, which nothing here does), and the TCP BTL stays off
SINGLETON_MCA = {"OMPI_MCA_ess_singleton_isolated": "1", "OMPI_MCA_btl": "self,vader",
                 "OMPI_MCA_oob_tcp_if_include": "lo", "OMPI_MCA_oob_tcp_disable_ipv6_family": "1"}


def comm():
    """MPI's world communicator (mpi4py; initialises MPI on first use)."""
    if launched_ranks() == 1 and "mpi4py.MPI" not in sys.modules:
        for name, value in SINGLETON_MCA.items():
            os.environ.setdefault(name, value)
    from mpi4py import MPI

    return MPI.COMM_WORLD


def mpi_started() -> bool:
    """Whether this process has initialised MPI (without initialising it)."""
    mod = sys.modules.get("mpi4py.MPI")
    return mod is not None and bool(mod.Is_initialized())


def _finalized() -> bool:
    """Whether MPI has been finalised (at interpreter exit: a factorisation freed after it ends with it)."""
    mod = sys.modules.get("mpi4py.MPI")
    return mod is not None and bool(mod.Is_finalized())


def ranks() -> int:
    return comm().Get_size()


def _peak_bytes() -> int:
    """This process's peak resident set (Linux reports ru_maxrss in KiB)."""
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


# -- the host's side ------------------------------------------------------------------------------------
class HostInstance:
    """A MUMPS instance on all ranks, driven from rank 0: ``job`` runs the same JOB everywhere."""

    _next_id = 0

    def __init__(self, settings: dict[int, int]) -> None:
        """``settings``: ICNTL values (index from 1) every rank sets before the analysis."""
        HostInstance._next_id += 1
        self.id = HostInstance._next_id
        self.comm = comm()
        self._tell(("init", self.id, settings))
        self.mumps = _new_instance(self.comm, settings)
        self.factor_megabytes: list[int] = []

    def _tell(self, message: tuple) -> None:
        for rank in range(1, self.comm.Get_size()):
            self.comm.send(message, dest=rank, tag=_TAG)

    def job(self, job: int) -> int:
        """JOB on every rank; returns INFOG(1). After a factorisation (JOB 2 or 4) ``factor_megabytes``
        holds INFO(16) of each rank: the MB MUMPS allocated for it there."""
        self._tell(("job", self.id, job))
        code = self.mumps.call(job)
        if job in (2, 4, 5, 6):
            self.factor_megabytes = self.comm.gather(int(self.mumps.s.info[15]), root=0)
        return code

    def free(self) -> None:
        """JOB = −2 on every rank; nothing once the serving ranks were released or MPI finalised (the
        instance ends with MPI)."""
        if self.mumps.alive and not _released and not _finalized():
            self._tell(("free", self.id))
            self.mumps.free()


def _new_instance(communicator, settings: dict[int, int]) -> Instance:
    inst = Instance(communicator.py2f())
    for i, v in settings.items():
        inst.icntl(i, v)
    return inst


def peak_memory_bytes() -> list[int]:
    """The peak resident set of every rank so far (bytes, rank 0 first); on rank 0 only."""
    c = comm()
    for rank in range(1, c.Get_size()):
        c.send(("memory",), dest=rank, tag=_TAG)
    return c.gather(_peak_bytes(), root=0)


def parallel_summary() -> dict[str, Any] | None:
    """summary.json's ``parallel`` (``{"ranks", "peak_memory_bytes"}``) when this process uses MPI, else
    None (MPI is not initialised for it)."""
    if not mpi_started():
        return None
    return {"ranks": ranks(), "peak_memory_bytes": peak_memory_bytes()}


_released = False


def release() -> None:
    """Tell the serving ranks to exit (rank 0, once it is done)."""
    global _released
    _released = True
    c = comm()
    for rank in range(1, c.Get_size()):
        c.send(("exit",), dest=rank, tag=_TAG)


# -- the serving ranks ----------------------------------------------------------------------------------
def serve() -> None:
    """Ranks 1..N−1: follow rank 0's MUMPS calls until it says ``exit``."""
    c = comm()
    instances: dict[int, Instance] = {}
    while True:
        while not c.Iprobe(source=0, tag=_TAG):
            time.sleep(_POLL_SECONDS)
        message = c.recv(source=0, tag=_TAG)
        kind = message[0]
        try:
            if kind == "exit":
                break
            if kind == "init":
                instances[message[1]] = _new_instance(c, message[2])
            elif kind == "job":
                inst, job = instances[message[1]], message[2]
                inst.call(job)
                if job in (2, 4, 5, 6):
                    c.gather(int(inst.s.info[15]), root=0)
            elif kind == "free":
                instances.pop(message[1]).free()
            elif kind == "memory":
                c.gather(_peak_bytes(), root=0)
        except Exception as exc:  # noqa: BLE001 — a serving rank cannot go on alone: end the whole run
            print(f"rank {c.Get_rank()}: {type(exc).__name__}: {exc}", file=sys.stderr)
            c.Abort(3)
    for inst in instances.values():
        inst.free()


def run_on_host(main: Callable[[], Any]) -> Any:
    """``main()`` on rank 0, the others serving it until it returns or fails; returns its value on rank 0
    and None on the others. Without a launcher (one process) it is just ``main()``."""
    if launched_ranks() <= 1:
        return main()
    if comm().Get_rank() != 0:
        serve()
        return None
    try:
        return main()
    finally:
        release()
