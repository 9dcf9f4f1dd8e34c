"""dolfinx, petsc4py, gmsh and pyvista import in any order (tools/libmpi_first.py).

Each import runs in a fresh interpreter: the order matters only in a new process.
"""

import filecmp
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[1] / "tools" / "libmpi_first.py"
VENV_LIBMPI = Path(sys.prefix) / "lib" / "libmpi.so.12"

# The binding first, then MPI and a distributed dolfinx mesh: 6 tetrahedra per cube.
FIRST_THEN_MPI = """
import {module}
from mpi4py import MPI
import dolfinx.mesh
mesh = dolfinx.mesh.create_unit_cube(MPI.COMM_SELF, 2, 2, 2)
copies = {{line.split()[-1] for line in open("/proc/self/maps") if "libmpi.so" in line}}
print(mesh.topology.index_map(3).size_local, len(copies))
"""


def run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )


@pytest.mark.parametrize("module", ["dolfinx", "petsc4py.PETSc", "gmsh", "pyvista"])
def test_binding_imported_before_mpi4py(module):
    done = run(FIRST_THEN_MPI.format(module=module))
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["48", "1"]  # 48 cells, one libmpi in the process


def test_start_up_loads_no_mpi():
    # The hook only registers a finder: no mpi4py, no libmpi until a binding is imported.
    code = (
        "import sys\n"
        "maps = open('/proc/self/maps').read()\n"
        "print('mpi4py' in sys.modules, 'libmpi' in maps)\n"
    )
    done = run(code)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "False"]


@pytest.mark.skipif(not VENV_LIBMPI.exists(), reason="MPI is not the mpich wheel's")
def test_installed_hook_is_current():
    site = Path(sysconfig.get_paths()["purelib"])
    installed = site / "_dd_contact_libmpi_first.py"
    assert installed.exists(), "run `make venv` (or python tools/libmpi_first.py)"
    assert filecmp.cmp(installed, TOOL, shallow=False)
    pth = site / "_dd_contact_libmpi_first.pth"
    assert pth.read_text() == "import _dd_contact_libmpi_first\n"
