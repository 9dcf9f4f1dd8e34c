"""Let dolfinx, petsc4py and slepc4py be imported before mpi4py in this environment.

The PyPI ``mpich`` wheel puts ``libmpi.so.12`` in ``<venv>/lib``, a directory on no
binding's library search path: mpi4py finds it there and loads it, after which the
``libmpi.so.12`` dependency of dolfinx's and PETSc's libraries resolves to the loaded copy.
Imported first, they fail with ``libmpi.so.12: cannot open shared object file``.

Installed (``python tools/libmpi_first.py``, run by the Makefile's venv step), this file
is copied into the interpreter's site-packages as ``_dd_contact_libmpi_first.py`` with a
``.pth`` file that imports it at start-up. Importing it only puts a finder first on
``sys.meta_path``: nothing is loaded until the first import of one of those bindings,
which then loads the same ``libmpi.so.12`` file mpi4py loads (the loader keeps one copy)
and removes the finder. It does not initialise MPI and finds no module itself.
"""

import os
import sys

NEEDS_LIBMPI = frozenset({"dolfinx", "petsc4py", "slepc4py"})
MODULE = "_dd_contact_libmpi_first"


class LoadLibmpiFirst:
    """A meta-path finder that loads ``<prefix>/lib/libmpi.so.12`` before a binding needs it."""

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        """Load libmpi on the first import of a binding; always leave the finding to others."""
        if name.partition(".")[0] in NEEDS_LIBMPI:
            sys.meta_path[:] = [f for f in sys.meta_path if f is not cls]
            libmpi = os.path.join(sys.prefix, "lib", "libmpi.so.12")
            if os.path.exists(libmpi):  # an environment with a system MPI needs nothing
                import ctypes

                ctypes.CDLL(libmpi, os.RTLD_LAZY | os.RTLD_LOCAL)  # mpi4py's mode on Linux
        return None


def install(site_packages: str) -> None:
    """Copy this file into ``site_packages`` and add the ``.pth`` file that imports it."""
    import py_compile  # here, not at the top: start-up imports this file and needs neither
    import shutil

    module = os.path.join(site_packages, f"{MODULE}.py")
    shutil.copyfile(__file__, module)
    py_compile.compile(module, doraise=True)  # start-up then reads bytecode, whatever the flags
    with open(os.path.join(site_packages, f"{MODULE}.pth"), "w") as pth:
        pth.write(f"import {MODULE}\n")


if __name__ == "__main__":
    import sysconfig

    target = sysconfig.get_paths()["purelib"]
    install(target)
    print(f"libmpi_first: installed into {target}")
elif not any(getattr(f, "__name__", "") == "LoadLibmpiFirst" for f in sys.meta_path):
    sys.meta_path.insert(0, LoadLibmpiFirst)
