"""dd_contact: fast 3-D contact analysis by domain/boundary decomposition in dolfinx."""

from mpi4py import MPI as _MPI  # noqa: F401  (loads libmpi before petsc4py)

from dd_contact.errors import (
    CoarseTimeStepWarning,
    ContactCycleWarning,
    ContactIterationError,
    EnergyGrowthWarning,
    InaccurateSolutionError,
    InputError,
    PenaltyRangeWarning,
    SingularMatrixError,
    SurfaceResolutionWarning,
)
from dd_contact.iteration import ContactSettings
from dd_contact.obstacles import Cylinder, Plane, Sphere, UserObstacle
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import (
    DEFAULT_KAPPA,
    KAPPA_VERIFIED,
    ContactBoundary,
    ContactInterface,
    Interface,
    Penalty,
    Scene,
)
from dd_contact.solvers.schedule import ALGORITHMS
from dd_contact.subdomains import Material, Subdomain

__version__ = "0.1.0"

__all__ = [
    "ALGORITHMS",
    "DEFAULT_KAPPA",
    "KAPPA_VERIFIED",
    "CoarseTimeStepWarning",
    "ContactBoundary",
    "ContactCycleWarning",
    "ContactInterface",
    "ContactIterationError",
    "ContactSettings",
    "Cylinder",
    "EnergyGrowthWarning",
    "InaccurateSolutionError",
    "InputError",
    "Interface",
    "Material",
    "Penalty",
    "PenaltyRangeWarning",
    "Plane",
    "Scene",
    "SingularMatrixError",
    "Sphere",
    "StaticProblem",
    "Subdomain",
    "SurfaceResolutionWarning",
    "TransientProblem",
    "UserObstacle",
    "__version__",
]
