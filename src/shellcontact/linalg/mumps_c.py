"""A ctypes binding of MUMPS's C interface ``dmumps_c`` (double precision, the installed
``dmumps_c.h``/``dmumps_struc.h`` of MUMPS 5.5, 32-bit MUMPS_INT): the structure ``DmumpsStruc`` and
``Instance``, one MUMPS instance on every rank of a communicator. Each rank of the communicator must
make the same sequence of calls (``linalg.mpi`` has the other ranks follow rank 0's).

MUMPS is the engine; this module only lays out its structure (``tests/test_mumps.py`` checks the field
offsets against the installed header compiled by the C compiler).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os

_INT = ctypes.c_int
_INT8 = ctypes.c_int64
_REAL = ctypes.c_double
_P_INT = ctypes.POINTER(_INT)
_P_REAL = ctypes.POINTER(_REAL)


class DmumpsStruc(ctypes.Structure):
    """``DMUMPS_STRUC_C`` field by field (dmumps_c.h, MUMPS 5.5.1)."""

    _fields_ = [
        ("sym", _INT), ("par", _INT), ("job", _INT), ("comm_fortran", _INT),
        ("icntl", _INT * 60), ("keep", _INT * 500), ("cntl", _REAL * 15), ("dkeep", _REAL * 230),
        ("keep8", _INT8 * 150), ("n", _INT), ("nblk", _INT), ("nz_alloc", _INT),
        # assembled entry
        ("nz", _INT), ("nnz", _INT8), ("irn", _P_INT), ("jcn", _P_INT), ("a", _P_REAL),
        # distributed entry
        ("nz_loc", _INT), ("nnz_loc", _INT8), ("irn_loc", _P_INT), ("jcn_loc", _P_INT), ("a_loc", _P_REAL),
        # element entry
        ("nelt", _INT), ("eltptr", _P_INT), ("eltvar", _P_INT), ("a_elt", _P_REAL),
        # matrix by blocks
        ("blkptr", _P_INT), ("blkvar", _P_INT),
        ("perm_in", _P_INT), ("sym_perm", _P_INT), ("uns_perm", _P_INT),
        ("colsca", _P_REAL), ("rowsca", _P_REAL), ("colsca_from_mumps", _INT), ("rowsca_from_mumps", _INT),
        ("rhs", _P_REAL), ("redrhs", _P_REAL), ("rhs_sparse", _P_REAL), ("sol_loc", _P_REAL), ("rhs_loc", _P_REAL),
        ("irhs_sparse", _P_INT), ("irhs_ptr", _P_INT), ("isol_loc", _P_INT), ("irhs_loc", _P_INT),
        ("nrhs", _INT), ("lrhs", _INT), ("lredrhs", _INT), ("nz_rhs", _INT), ("lsol_loc", _INT),
        ("nloc_rhs", _INT), ("lrhs_loc", _INT),
        ("schur_mloc", _INT), ("schur_nloc", _INT), ("schur_lld", _INT),
        ("mblock", _INT), ("nblock", _INT), ("nprow", _INT), ("npcol", _INT),
        ("info", _INT * 80), ("infog", _INT * 80), ("rinfo", _REAL * 40), ("rinfog", _REAL * 40),
        ("deficiency", _INT), ("pivnul_list", _P_INT), ("mapping", _P_INT),
        ("size_schur", _INT), ("listvar_schur", _P_INT), ("schur", _P_REAL),
        ("instance_number", _INT), ("wk_user", _P_REAL),
        ("version_number", ctypes.c_char * 32), ("ooc_tmpdir", ctypes.c_char * 256),
        ("ooc_prefix", ctypes.c_char * 64), ("write_problem", ctypes.c_char * 256), ("lwk_user", _INT),
        ("save_dir", ctypes.c_char * 256), ("save_prefix", ctypes.c_char * 256),
        ("metis_options", _INT * 40),
    ]


#: MUMPS's error codes INFOG(1) that callers can act on (the MUMPS 5.5 users' guide, section 8)
ERRORS = {
    -6: "the matrix is singular in structure",
    -8: "the integer work array is too small (ICNTL(14))",
    -9: "the real work array is too small (ICNTL(14))",
    -10: "the matrix is numerically singular",
    -13: "a memory allocation failed (out of memory)",
    -40: "the matrix was declared symmetric positive definite but a negative or null pivot was met",
    -90: "out-of-core: error while writing the factors to disk (ICNTL(22) directory full?)",
}


@functools.cache
def library() -> ctypes.CDLL:
    """The parallel ``libdmumps`` (Debian: libmumps-dev); MPI must be initialised (mpi4py imported) first
    so that its symbols are there."""
    name = ctypes.util.find_library("dmumps")
    if name is None:
        raise OSError("libdmumps not found (Debian: apt-get install libmumps-dev)")
    # DEEPBIND: MUMPS's BLAS calls bind to its own BLAS even when MKL (PARDISO) was loaded first; bound to MKL's,
    # the demo's force at refine 1 moved 1.5e-9 off (against 4.6e-11 from PARDISO's): tests/test_mumps.py
    lib = ctypes.CDLL(name, mode=ctypes.RTLD_GLOBAL | os.RTLD_DEEPBIND)
    lib.dmumps_c.argtypes = [ctypes.POINTER(DmumpsStruc)]
    lib.dmumps_c.restype = None
    return lib


class Instance:
    """One MUMPS instance (JOB = −1 done) for a symmetric positive definite matrix (SYM = 1), the host
    taking part in the work (PAR = 1), on the Fortran communicator ``comm_fortran``; quiet (ICNTL(1-4))."""

    def __init__(self, comm_fortran: int) -> None:
        self._lib = library()
        self.s = DmumpsStruc()
        self.s.sym, self.s.par, self.s.comm_fortran = 1, 1, comm_fortran
        self.call(-1)
        self.version = self.s.version_number.decode().strip()
        for i, v in ((1, -1), (2, -1), (3, -1), (4, 0)):  # no output streams: errors come back in INFOG
            self.icntl(i, v)
        self.alive = True

    def icntl(self, i: int, value: int) -> None:
        """Set ICNTL(i) (MUMPS counts from 1)."""
        self.s.icntl[i - 1] = value

    def call(self, job: int) -> int:
        """dmumps_c with JOB = ``job``; returns INFOG(1) (negative: an error, the same on every rank)."""
        self.s.job = job
        self._lib.dmumps_c(ctypes.byref(self.s))
        return int(self.s.infog[0])

    def error(self) -> str:
        """What INFOG(1), INFOG(2) mean."""
        code, detail = int(self.s.infog[0]), int(self.s.infog[1])
        return f"MUMPS error INFOG(1) = {code}, INFOG(2) = {detail}: {ERRORS.get(code, 'see the MUMPS users guide')}"

    def free(self) -> None:
        """JOB = −2: release the instance's memory (idempotent)."""
        if self.alive:
            self.alive = False
            self.call(-2)
