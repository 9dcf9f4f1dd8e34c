"""dd_contact: fast 3-D contact analysis by domain/boundary decomposition in dolfinx."""

from mpi4py import MPI as _MPI  # noqa: F401  (loads libmpi before petsc4py)

from dd_contact.problem import ALGORITHMS, StaticProblem
from dd_contact.scene import (
    DEFAULT_KAPPA,
    InputError,
    Interface,
    Material,
    Penalty,
    Scene,
    Subdomain,
)

__version__ = "0.1.0"

__all__ = [
    "ALGORITHMS",
    "DEFAULT_KAPPA",
    "InputError",
    "Interface",
    "Material",
    "Penalty",
    "Scene",
    "StaticProblem",
    "Subdomain",
    "__version__",
]
