"""Every BLAS of a timed process on one thread (one core each): a benchmark's environment.

The benchmarks time each algorithm in a process of its own; pinning the BLAS threads keeps
two processes from sharing a core unseen and makes their CPU and wall times comparable.
"""

from __future__ import annotations

#: The environment variables that pin OpenBLAS, OpenMP, MKL and BLIS to one thread.
PINNED = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "BLIS_NUM_THREADS": "1",
}
