"""Whether this process was started by an MPI launcher, and with how many processes, from the environment
alone: the command line asks before anything heavy is imported (``linalg.mpi`` does the rest)."""

from __future__ import annotations

import os

#: environment variables by which the common launchers give the size (Open MPI, MPICH/Hydra, a Slurm step)
SIZE_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS")


def launched_ranks() -> int:
    """The number of processes mpiexec (or srun) started (1 without a launcher); does not initialise MPI."""
    for name in SIZE_VARIABLES:
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return 1
