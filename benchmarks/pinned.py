"""Every BLAS of a timed process on one thread (one core each), and a worker run so.

The benchmarks time each algorithm in a process of its own; pinning the BLAS threads keeps
two processes from sharing a core unseen and makes their CPU and wall times comparable.
"""

from __future__ import annotations

import json
import os
import subprocess

#: The environment variables that pin OpenBLAS, OpenMP, MKL and BLIS to one thread.
PINNED = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "BLIS_NUM_THREADS": "1",
}


def pinned_record(command: list[str]) -> dict:
    """Run a worker ``command`` in a process of its own with :data:`PINNED` BLAS threads.

    Returns the JSON record the worker printed last on stdout (it fails loudly if the worker
    did).
    """
    env = {**os.environ, **PINNED}
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])
