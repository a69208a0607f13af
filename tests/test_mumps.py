"""The mumps backend (MUMPS over MPI, issue 27): its ctypes layout against the installed header, its solves
against PARDISO on one rank, and one model on two MPI processes giving PARDISO's force to 1e-9.

Skipped, with the reason, where mpi4py, the parallel libdmumps or mpiexec are missing (`make mpi-packages`
installs them on Debian).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from shellcontact import linalg

ROOT = Path(__file__).resolve().parents[1]
HAVE_MUMPS = "mumps" in linalg.available_backends()
MPIEXEC = shutil.which("mpiexec")
REFERENCE = "pardiso" if "pardiso" in linalg.available_backends() else "superlu"
needs_mumps = pytest.mark.skipif(not HAVE_MUMPS, reason="mumps backend not installed here: needs mpi4py (extra "
                                 "shellcontact[mpi]) and the parallel libdmumps (make mpi-packages)")
needs_mpiexec = pytest.mark.skipif(not (HAVE_MUMPS and MPIEXEC), reason="no mpiexec or no mumps backend here: the "
                                   "runs on several MPI processes need both (make mpi-packages)")


def mpiexec(n: int) -> tuple[list[str], dict[str, str]]:
    """The mpiexec command for n ranks and its environment: Open MPI refuses root without its two variables
    (CI runs as root) and more ranks than cores without --oversubscribe."""
    version = subprocess.run([MPIEXEC, "--version"], capture_output=True, text=True).stdout
    openmpi = "Open MPI" in version or "OpenRTE" in version
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_mpi_yield_when_idle": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    return [MPIEXEC, *(["--oversubscribe"] if openmpi else []), "-n", str(n)], env


@pytest.mark.skipif(shutil.which("cc") is None or not Path("/usr/include/dmumps_c.h").exists(),
                    reason="no C compiler or no /usr/include/dmumps_c.h (libmumps-dev) to check the layout against")
def test_structure_layout_is_the_installed_header(tmp_path):
    """Every field offset of ``mumps_c.DmumpsStruc`` and its size are those the C compiler gives the header."""
    from shellcontact.linalg.mumps_c import DmumpsStruc

    names = [name for name, _ in DmumpsStruc._fields_]
    src = tmp_path / "offsets.c"
    src.write_text("#include <stdio.h>\n#include <stddef.h>\n#include <dmumps_c.h>\nint main(void) {\n"
                   + "".join(f'  printf("{n} %zu\\n", offsetof(DMUMPS_STRUC_C, {n}));\n' for n in names)
                   + '  printf("sizeof %zu\\n", sizeof(DMUMPS_STRUC_C));\n  return 0;\n}\n')
    subprocess.run(["cc", str(src), "-o", str(tmp_path / "offsets")], check=True)
    out = subprocess.run([str(tmp_path / "offsets")], capture_output=True, text=True, check=True).stdout
    c = {k: int(v) for k, v in (line.split() for line in out.splitlines())}
    import ctypes

    assert {n: getattr(DmumpsStruc, n).offset for n in names} == {n: c[n] for n in names}
    assert ctypes.sizeof(DmumpsStruc) == c["sizeof"]


@pytest.fixture(scope="module")
def contact_system():
    """The demo case's reduced stiffness and contact rows at the coarsest mesh (18k unknowns)."""
    import shellcontact
    from shellcontact.analysis.discretization import discretize

    d = discretize(shellcontact.load_case(ROOT / "examples" / "paper_panel.toml"))
    return d.Ar, d.Br


@needs_mumps
def test_solves_match_pardiso_on_one_rank(contact_system):
    """One rank: a solve, a block of columns of Bᵀ (sparse right-hand sides, unrefined) and a refactor agree
    with PARDISO (measured 1.5e-14, 9.7e-12 unrefined, 4.5e-15 relative: asserted 1e-13, 1e-10, 3e-14)."""
    A, B = contact_system
    b = np.random.default_rng(7).standard_normal(A.shape[0])
    mumps, ref = linalg.factorize(A, "mumps"), linalg.factorize(A, REFERENCE)
    x = mumps.solve(b)
    assert np.max(np.abs(x - ref.solve(b))) <= 1e-13 * np.max(np.abs(x))
    assert mumps.backward_error < 1e-14
    BT = B[:40].T.toarray()
    X = mumps.solve_many(BT, refine=False)  # 40 columns of a few nonzeros: MUMPS's sparse right-hand sides
    assert np.max(np.abs(X - ref.solve_many(BT))) <= 1e-10 * np.max(np.abs(X))
    info = mumps.info()
    assert info["ranks"] == 1 and len(info["factor_megabytes_per_rank"]) == 1 and info["factor_nnz"] > A.nnz // 2
    A2 = sp.csr_matrix(A * 3.0)
    assert np.max(np.abs(mumps.refactor(A2).solve(b) - x / 3.0)) <= 3e-14 * np.max(np.abs(x))


@needs_mumps
def test_out_of_core_gives_the_same_solution(contact_system, tmp_path, monkeypatch):
    """``[solver] out_of_core``: the factors on disk (ICNTL(22) = 1, files in $MUMPS_OOC_TMPDIR) solve alike
    (measured 2.1e-16 relative; asserted 2e-15)."""
    from shellcontact.linalg import mumps

    A, _ = contact_system
    b = np.random.default_rng(8).standard_normal(A.shape[0])
    x = linalg.factorize(A, "mumps").solve(b)
    monkeypatch.setenv("MUMPS_OOC_TMPDIR", str(tmp_path))
    mumps.configure(out_of_core=True)
    try:
        f = linalg.factorize(A, "mumps")
        assert f.info()["out_of_core"] is True
        assert np.max(np.abs(f.solve(b) - x)) <= 2e-15 * np.max(np.abs(x))
        f.free()
    finally:
        mumps.configure(out_of_core=False)


@needs_mpiexec
def test_info_names_version_and_ranks():
    cmd, env = mpiexec(2)
    r = subprocess.run([*cmd, sys.executable, "-m", "shellcontact.cli", "info"], capture_output=True, text=True,
                       env=env, timeout=120, check=True)
    assert "on 2 MPI rank(s)" in r.stdout and "MUMPS 5." in r.stdout
    assert r.stdout.count("shellcontact 0.") == 1  # rank 0 alone prints


@needs_mpiexec
def test_failure_on_rank_0_ends_every_rank(tmp_path):
    """A bad --set on rank 0 is its usual exit 2, and the serving rank exits with it (no hang)."""
    cmd, env = mpiexec(2)
    r = subprocess.run([*cmd, sys.executable, "-m", "shellcontact.cli", "run", str(ROOT / "examples" /
                        "paper_panel.toml"), "--set", "mesh.refine=-1", "--set", "solver.backend=mumps", "-o",
                        str(tmp_path / "out")], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 2 and "mesh.refine" in r.stderr


@pytest.mark.slow
@needs_mpiexec
def test_two_ranks_give_the_pardiso_force(tmp_path):
    """Issue 27's acceptance: ``mpiexec -n 2 shellcontact run examples/paper_panel.toml --set mesh.refine=1
    --set solver.backend=mumps`` gives PARDISO's force to 1e-9 relative (measured 1.2e-10), and its
    summary.json says it ran on two ranks with a peak memory for each."""
    import shellcontact

    case = ROOT / "examples" / "paper_panel.toml"
    cmd, env = mpiexec(2)
    r = subprocess.run([*cmd, sys.executable, "-m", "shellcontact.cli", "run", str(case), "--set", "mesh.refine=1",
                        "--set", "solver.backend=mumps", "-o", str(tmp_path / "out"), "--no-figures"],
                       capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["backend"] == "mumps"
    assert summary["parallel"]["ranks"] == 2
    peaks = summary["parallel"]["peak_memory_bytes"]
    assert len(peaks) == 2 and all(p > 20e6 for p in peaks)  # each rank at least its Python interpreter
    reference = shellcontact.solve(shellcontact.load_case(case, ["mesh.refine=1"]), backend=REFERENCE).summary()
    force, expected = summary["contact"][0]["force"][2], reference["contact"][0]["force"][2]
    assert abs(force - expected) <= 1e-9 * abs(expected)
