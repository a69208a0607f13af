"""The mumps backend (MUMPS over MPI, issue 27): its ctypes layout against the installed header, its solves
against PARDISO on one rank, its Schur complement of the contact rows (ICNTL(19)) against dense B A⁻¹ Bᵀ on one
and two ranks, the contact run on that path against PARDISO's force, and one model on two MPI processes giving
PARDISO's force to 1e-9.

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


def _small_qp():
    """A plate pressed by a sphere, 1.7k unknowns and 625 contact rows (tests/synthetic.py)."""
    from synthetic import plate_qp

    return plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0)


@needs_mumps
def test_schur_option_equals_dense_schur_complement():
    """``factorize(A, "mumps", border=B)``: MUMPS's Schur option gives S = B A⁻¹ Bᵀ equal to numpy's dense one
    (measured 9.8e-13 relative to max |S|, PARDISO's bordered form 5.4e-13, numpy's own round-off being
    cond(A)·ε = 6.4e4·ε; asserted 5e-12), exactly symmetric, and the same factors solve with A (measured 1.2e-12;
    asserted 5e-12); a refactor drops S and solves alike (measured 1.9e-13; asserted 1e-12)."""
    from shellcontact.linalg import DenseSchur

    qp = _small_qp()
    A, Bd = qp.A.toarray(), qp.B.toarray()
    dense = Bd @ np.linalg.solve(A, Bd.T)
    f = linalg.factorize(qp.A, "mumps", border=qp.B)
    assert isinstance(f.schur, DenseSchur) and f.info()["schur_rows"] == qp.m
    S = f.schur.columns(np.arange(qp.m))
    assert np.max(np.abs(S - dense)) <= 5e-12 * np.max(np.abs(dense))
    assert np.array_equal(S, S.T)
    b = np.random.default_rng(3).standard_normal(qp.n)
    x = f.solve(b)
    assert np.max(np.abs(x - np.linalg.solve(A, b))) <= 5e-12 * np.max(np.abs(x))
    assert f.refactor(qp.A).schur is None
    assert np.max(np.abs(f.solve(b) - x)) <= 1e-12 * np.max(np.abs(x))


@pytest.mark.slow
@needs_mumps
def test_contact_on_the_schur_path_gives_the_pardiso_force():
    """The demo at refine 1 (68k unknowns, above ``substructure.MIN_UNKNOWNS``) on one rank: the contact solve
    takes MUMPS's Schur complement (a few solves instead of one per column of S: 4 against 561 measured) and
    gives PARDISO's force to 1e-9 (measured 1.7e-11 against the extended-precision force, PARDISO 2.9e-11 from
    it: 4.6e-11 apart), also with PARDISO (MKL) loaded first."""
    import shellcontact

    case = ROOT / "examples" / "paper_panel.toml"
    runs = {be: shellcontact.solve(shellcontact.load_case(case, ["mesh.refine=1"]), backend=be)
            for be in (REFERENCE, "mumps")}  # PARDISO first: MKL loaded before MUMPS (its BLAS then bound to MKL's
    # without RTLD_DEEPBIND, 1.5e-9 off: mumps_c.library)
    assert runs["mumps"].contact.solution.timings["n_solves"] <= 20
    force, expected = (runs[be].summary()["contact"][0]["force"][2] for be in ("mumps", REFERENCE))
    assert abs(force - expected) <= 1e-9 * abs(expected)


_TWO_RANK_SCHUR = """
import sys, numpy as np
sys.path.insert(0, {tests!r})
from synthetic import plate_qp
from shellcontact import linalg
from shellcontact.linalg.mpi import run_on_host, ranks

def main():
    qp = plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0)
    Bd = qp.B.toarray()
    dense = Bd @ np.linalg.solve(qp.A.toarray(), Bd.T)
    f = linalg.factorize(qp.A, "mumps", border=qp.B)
    S = f.schur.columns(np.arange(qp.m))
    print(ranks(), np.max(np.abs(S - dense)) / np.max(np.abs(dense)), f.info()["factor_megabytes_per_rank"])
    f.free()

run_on_host(main)
"""


@needs_mpiexec
def test_schur_option_on_two_ranks(tmp_path):
    """Two ranks: the Schur complement comes back whole on rank 0 (ICNTL(19) = 1, centralised) and equals the
    dense B A⁻¹ Bᵀ (measured 9.8e-13, as on one rank; asserted 5e-12); both ranks hold factors."""
    script = tmp_path / "schur2.py"
    script.write_text(_TWO_RANK_SCHUR.format(tests=str(ROOT / "tests")))
    cmd, env = mpiexec(2)
    r = subprocess.run([*cmd, sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    ranks, error, megabytes = r.stdout.split(maxsplit=2)
    assert int(ranks) == 2 and float(error) <= 5e-12
    assert len(json.loads(megabytes)) == 2


@needs_mumps
def test_a_singleton_starts_no_daemon_and_listens_nowhere():
    """The mumps backend in a plain run initialises MPI as a singleton: no helper daemon (Open MPI's orted,
    whose PMIx server listened on 0.0.0.0 and ::) and no listening socket (linalg.mpi.SINGLETON_MCA)."""
    code = ("import psutil, scipy.sparse as sp\nfrom shellcontact import linalg\n"
            "linalg.factorize(sp.eye(10, format='csr') * 2.0, 'mumps')\nme = psutil.Process()\n"
            "procs = [me, *me.children(recursive=True)]\nprint([p.name() for p in procs[1:]],"
            " [c.laddr for p in procs for c in p.net_connections('inet') if c.status == psutil.CONN_LISTEN])")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_"))}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[] []"


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
