"""Shared helpers of the benchmark scripts: machine description, stage timing and peak memory, tables.

Every measurement that reports memory runs in a fresh subprocess (``run_worker``), so that the
peak resident set (``ru_maxrss``) belongs to that measurement alone; inside it, ``Stages``
records per stage the wall time and the peak of Python/NumPy allocations (tracemalloc, which
sees NumPy's buffers but not memory allocated inside MKL/CHOLMOD — those are covered by the
process's maximum RSS). Wall time is what the targets mean; the process CPU time is recorded
too because this machine's 2 cores are shared: under load the wall time of a single-threaded
run overstates its cost, and the CPU time is the fairer figure for a ratio.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import resource
import subprocess
import sys
import time
import tracemalloc
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path

HERE = Path(__file__).resolve().parent
THREADS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def machine() -> dict:
    """CPU model, cores, memory, library versions: printed with every table."""
    cpu = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem_gb = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                mem_gb = round(int(line.split()[1]) / 2**20, 1)
    except OSError:
        pass
    import numpy
    import scipy
    import skfem

    info = {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory_gb": mem_gb,
        "threads": {k: os.environ.get(k, "unset") for k in THREADS},
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "scikit-fem": skfem.__version__ if hasattr(skfem, "__version__") else "?",
        "date": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
    }
    try:
        info["load_average"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    return info


def machine_line(info: dict) -> str:
    threads = ",".join(f"{k.split('_')[0]}={v}" for k, v in info["threads"].items())
    return (
        f"machine: {info['cpu']}, {info['cores']} cores, {info['memory_gb']} GB; threads "
        f"{threads}; python {info['python']}, "
        f"numpy {info['numpy']}, scipy {info['scipy']}, scikit-fem {info['scikit-fem']}; {info['date']}; "
        f"load average at start {info.get('load_average')}"
    )


def set_threads(n: int | None) -> None:
    """MKL/OpenBLAS/OpenMP threads of this process and of the workers it starts (None: leave as set)."""
    if n:
        for k in THREADS:
            os.environ[k] = str(n)


def single_thread_env() -> dict:
    env = dict(os.environ)
    for k in THREADS:
        env.setdefault(k, "1")
    return env


class Stages:
    """Wall time and peak traced allocation (bytes) of named stages."""

    def __init__(self, trace_memory: bool = True) -> None:
        self.times: dict[str, float] = {}
        self.cpu: dict[str, float] = {}
        self.peaks: dict[str, int] = {}
        self.trace = trace_memory
        if trace_memory and not tracemalloc.is_tracing():
            tracemalloc.start()

    @contextmanager
    def stage(self, name: str):
        if self.trace:
            tracemalloc.reset_peak()
            base = tracemalloc.get_traced_memory()[0]
        t0, c0 = time.perf_counter(), time.process_time()
        yield
        self.times[name] = self.times.get(name, 0.0) + time.perf_counter() - t0
        self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - c0
        if self.trace:
            self.peaks[name] = max(self.peaks.get(name, 0), tracemalloc.get_traced_memory()[1] - base)


def max_rss_bytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def emit(result: dict) -> None:
    """Last line of a worker's stdout: its result as JSON."""
    result["max_rss_bytes"] = max_rss_bytes()
    sys.stdout.write("\n" + json.dumps(result) + "\n")
    sys.stdout.flush()


def run_worker(script: Path, args: list[str], timeout: float = 3600.0, threads: int | None = None) -> dict:
    """Run ``script --worker args`` in a fresh interpreter and return its JSON result; ``threads``
    sets the worker's MKL/OpenBLAS/OpenMP threads (default: this process's, else 1)."""
    cmd = [sys.executable, str(script), "--worker", *args]
    env = single_thread_env()
    if threads:
        env.update({k: str(threads) for k in THREADS})
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def table(headers: list[str], rows: list[list]) -> str:
    def fmt(v):
        if isinstance(v, float):
            return f"{v:.3g}" if abs(v) < 1e4 else f"{v:.0f}"
        return str(v)

    cells = [[fmt(v) for v in r] for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) for i, h in enumerate(headers)]
    line = "| " + " | ".join(h.ljust(w) for h, w in zip(headers, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    body = ["| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |" for r in cells]
    return "\n".join([line, sep, *body])


def target(value, goal, unit, peer, **extra) -> dict:
    return {"value": value, "goal": goal, "unit": unit, "peer": peer, **extra}


# --- the discrete contact QP of a case, as shellcontact.analysis.pipeline.solve builds it -----------------------------


def export_qp_parts(case, contact_points: str | None = None):
    """(qp, operator, reduction, space) of ``case``: the reduced QP exactly as ``analysis.solve`` builds it
    (``analysis.discretize``); ``contact_points`` defaults to the case's ``[solver] contact_points``.
    The operator gives the punch force of a multiplier vector (``operator.total_normal_force(Lambda)``);
    ``reduction.expand`` maps U_r to the full U.
    """
    from shellcontact.analysis.discretization import discretize

    d = discretize(case, contact_points or case.solver.contact_points)
    return d.qp(), d.operator, d.reduction, d.space


def export_qp(case, contact_points: str | None = None):
    """The reduced contact QP (``shellcontact.solvers.ContactQP``) of ``case``, as ``analysis.solve`` solves it."""
    return export_qp_parts(case, contact_points)[0]


def active_hash(active) -> str:
    """A fingerprint of an active set (boolean mask): equal hashes, identical sets."""
    import numpy as np

    return hashlib.sha1(np.packbits(np.asarray(active, dtype=bool)).tobytes()).hexdigest()


def richardson(forces: list[float]) -> dict:
    """Extrapolated force, observed order and digits of the finest level (needs ≥ 3 nested levels)."""
    if len(forces) < 3:
        return {"reason": f"needs 3 nested levels, got {len(forces)}"}
    f0, f1, f2 = forces[-3:]
    d1, d2 = f0 - f1, f1 - f2
    out: dict = {"differences": [forces[i + 1] - forces[i] for i in range(len(forces) - 1)]}
    if d2 == 0 or d1 / d2 <= 1.0:
        out["reason"] = "the differences between levels do not decrease monotonically: no asymptotic order"
        out["digits_vs_previous_level"] = -math.log10(abs(d2) / abs(f2)) if d2 else None
        return out
    p = math.log2(d1 / d2)
    f_inf = f2 + (f2 - f1) / (2**p - 1)
    out.update({"order": p, "extrapolated": f_inf, "error_finest": abs(f2 - f_inf) / abs(f_inf),
                "digits": -math.log10(abs(f2 - f_inf) / abs(f_inf))})
    if len(forces) >= 4:
        e0, e1 = forces[-4] - forces[-3], forces[-3] - forces[-2]
        out["order_previous_triple"] = math.log2(e0 / e1) if e1 and e0 / e1 > 0 else None
    return out
