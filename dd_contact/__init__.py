"""dd_contact: fast 3-D contact analysis by domain/boundary decomposition in dolfinx.

The public API is the list ``__all__`` below, and only it: the scene (``Scene``,
``Subdomain``, ``Interface``, ``ContactInterface``, ``ContactBoundary``, ``ContactPair``,
``Material``, the obstacles), the problems (``StaticProblem``, ``TransientProblem``), their
settings, errors and warnings, and the four modules a user calls beside them (``meshes``:
mesh builders; ``io``: output files; ``post``: results derived from a solution; ``viz``:
pictures), each with an ``__all__`` of its own, and ``load_results``, which reads a run's
output back. The other modules are the library these are built from. ``dd_contact.paper`` is
the paper's reproduction on top of the library (its operation-count model, its two examples,
the verification cases against closed forms, the algorithm comparison); no module of the
library imports it, only the ``dd-contact`` command (``cli``).
"""

from mpi4py import MPI as _MPI  # noqa: F401  (loads libmpi before petsc4py)

from dd_contact import io, meshes, post, viz
from dd_contact.decomposition import ContactCandidate, DecomposedScene, decompose
from dd_contact.errors import (
    CoarseContactWarning,
    CoarseTimeStepWarning,
    ContactCycleWarning,
    ContactIterationError,
    EnergyGrowthWarning,
    InaccurateSolutionError,
    InputError,
    OutputError,
    PenaltyRangeWarning,
    RunStopped,
    SingularMatrixError,
    SurfaceResolutionWarning,
)
from dd_contact.iteration import ContactSettings
from dd_contact.obstacles import Cylinder, Plane, Sphere, UserObstacle
from dd_contact.onemesh import OneMeshFields, fields_on_mesh
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.results import load_results
from dd_contact.scene import (
    DEFAULT_KAPPA,
    KAPPA_VERIFIED,
    ContactBoundary,
    ContactInterface,
    ContactPair,
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
    "CoarseContactWarning",
    "CoarseTimeStepWarning",
    "ContactBoundary",
    "ContactCandidate",
    "ContactCycleWarning",
    "ContactInterface",
    "ContactIterationError",
    "ContactPair",
    "ContactSettings",
    "Cylinder",
    "DecomposedScene",
    "EnergyGrowthWarning",
    "InaccurateSolutionError",
    "InputError",
    "Interface",
    "Material",
    "OneMeshFields",
    "OutputError",
    "Penalty",
    "PenaltyRangeWarning",
    "Plane",
    "RunStopped",
    "Scene",
    "SingularMatrixError",
    "Sphere",
    "StaticProblem",
    "Subdomain",
    "SurfaceResolutionWarning",
    "TransientProblem",
    "UserObstacle",
    "__version__",
    "decompose",
    "fields_on_mesh",
    "io",
    "load_results",
    "meshes",
    "post",
    "viz",
]
