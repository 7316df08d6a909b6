"""One BLAS/OpenMP thread per process unless the user chose otherwise.

kfio's matrices are small (n <= 40): a second BLAS thread only adds
synchronisation.  Measured on the 2-core development machine, 10^5 simulated
trajectories of 200 steps (n = 3) took 8.3 s of CPU and 12.5 s of wall time with
OpenBLAS's default of 2 threads, against 1.8-2.4 s of CPU and 2.7-3.5 s of wall
time with one (docs/speed.md).  The variables are read when NumPy loads its
BLAS, so this runs before anything imports NumPy: at the start of the CLI, and
before the service's forkserver starts its workers.  A value already set in the
environment is kept.
"""

from __future__ import annotations

import os
from typing import MutableMapping

#: The thread-count variables of OpenMP, OpenBLAS, MKL and numexpr.
THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS")


def one_thread_per_process(environ: MutableMapping[str, str] | None = None) -> None:
    """Set every variable of :data:`THREAD_ENV` to ``"1"`` where it is not set.

    Examples
    --------
    >>> env = {"OMP_NUM_THREADS": "4"}
    >>> one_thread_per_process(env)
    >>> env["OMP_NUM_THREADS"], env["OPENBLAS_NUM_THREADS"]
    ('4', '1')
    """
    env = os.environ if environ is None else environ
    for var in THREAD_ENV:
        env.setdefault(var, "1")
