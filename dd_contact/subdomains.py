"""A subdomain and its material: an independently meshed part of the body.

Each subdomain is an independent dolfinx mesh on a communicator of size one (one rank owns a
whole subdomain), with its displacement u, its supports (Dirichlet conditions) and its loads
(tractions and a body force, constant or changing with time). A :class:`dd_contact.scene.Scene`
holds the subdomains with the interface and the contacts that tie and press them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import cast

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import ufl

from dd_contact import arguments
from dd_contact.arguments import Region
from dd_contact.blocks import Block
from dd_contact.errors import InputError
from dd_contact.prescribed import Prescribed, Value

__all__ = ["MODES_TOLERANCE", "Material", "Reduction", "Subdomain"]

_FIELDS = ("u", "velocity", "acceleration")


@dataclass(frozen=True)
class Material:
    """Linear isotropic elastic material.

    Attributes:
        E: Young's modulus.
        nu: Poisson's ratio.
        rho: Density (only needed for dynamics).
    """

    E: float
    nu: float
    rho: float = 0.0

    def __post_init__(self):
        for name in ("E", "nu", "rho"):  # frozen: the checked floats replace what was given
            object.__setattr__(self, name, arguments.real(getattr(self, name), f"Material {name}"))
        if not self.E > 0:
            raise InputError(f"Material: Young's modulus E must be positive, got {self.E}")
        if not (-1.0 < self.nu < 0.5):
            raise InputError(f"Material: Poisson's ratio must lie in (-1, 0.5), got {self.nu}")
        if not self.rho >= 0:
            raise InputError(f"Material: density must be >= 0, got {self.rho}")

    @property
    def mu(self) -> float:
        """Shear modulus."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def lmbda(self) -> float:
        """First Lame parameter."""
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))


#: The eigensolver's default relative tolerance on a reduced subdomain's modes. The basis is
#: used whole, whatever its accuracy (the reduced matrices are its exact congruences), so a
#: mode's residual r moves the reduced model's frequencies by about r^2. The paper's bar
#: (50 x 12 x 10 and 100 x 25 x 10, m = 320): its contact-force history moves by 7e-9 of
#: the peak from 1e-8 to 1e-6 (2e-8 at 1e-3), and 320 modes at 87k interior dofs take 18
#: restarts instead of 21.
MODES_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Reduction:
    """How a subdomain is reduced (:meth:`Subdomain.reduce`; docs/solvers.md).

    Attributes:
        modes: Fixed-interface normal modes kept (the lowest).
        tolerance: The eigensolver's relative tolerance on those modes.
        if_cheaper: Reduce only if the reduced block's dense substitution is priced below
            the whole block's sparse one (``reduced_model.reduction_pays``).
        eigensolver: ``"block"`` (block solves, ``solvers.eigen``) or ``"slepc"``.
        out_of_core: Its interior's factor kept on disk by MUMPS (ICNTL(22) = 1).
    """

    modes: int
    tolerance: float = MODES_TOLERANCE
    if_cheaper: bool = False
    eigensolver: str = "block"
    out_of_core: bool = False


#: The eigensolvers of :meth:`Subdomain.reduce`.
EIGENSOLVERS = ("block", "slepc")


class Subdomain:
    """An independently meshed part of the body, Omega^(k).

    Args:
        mesh: A 3-D dolfinx mesh on a communicator of size one.
        material: Its material.
        name: A name used in messages and output.
        degree: Lagrange degree of the displacement (1 or 2).
    """

    def __init__(self, mesh: dolfinx.mesh.Mesh, material: Material, name: str, degree: int = 1):
        arguments.name(name, "Subdomain")
        arguments.one_rank_mesh(
            mesh,
            3,
            f"subdomain {name!r}",
            "surface meshes belong in an Interface or ContactInterface; create subdomain "
            "meshes with e.g. dd_contact.meshes.box(MPI.COMM_SELF, ...)",
        )
        arguments.instance(material, Material, f"subdomain {name!r}: material")
        if isinstance(degree, bool) or degree not in (1, 2):
            raise InputError(f"subdomain {name!r}: degree must be 1 or 2, got {degree!r}")
        self.mesh = mesh
        self.material = material
        self.name = name
        self.V = fem.functionspace(mesh, ("Lagrange", int(degree), (3,)))
        self._fields = {field: fem.Function(self.V, name=f"{field}_{name}") for field in _FIELDS}
        self._deferred: dict[str, Callable[[fem.Function], None]] = {}
        #: Time t, updated by the solvers before loads are assembled: use it in UFL loads.
        self.time = fem.Constant(mesh, 0.0)
        self.body_force: ufl.core.expr.Expr | None = None
        self.tractions: list[tuple[dolfinx.mesh.MeshTags, ufl.core.expr.Expr]] = []
        self._timed: list[tuple[fem.Constant, Callable[[float], Sequence[float]], str]] = []
        self._amplitudes: list[tuple[fem.Constant, Callable[[float], float], str]] = []
        #: The Dirichlet conditions (:meth:`fix`): dofs, and values at any time.
        self.prescribed = Prescribed(self.V, f"subdomain {name!r}")
        #: How the solvers represent it: ``None`` (whole), or a :class:`Reduction`.
        self.reduction: Reduction | None = None

    def _field(self, field: str) -> fem.Function:
        expansion = self._deferred.pop(field, None)
        if expansion is not None:
            expansion(self._fields[field])
        return self._fields[field]

    @property
    def u(self) -> fem.Function:
        """The displacement Function (a reduced subdomain's is expanded here when read)."""
        return self._field("u")

    @property
    def velocity(self) -> fem.Function:
        """Velocity: set it (e.g. ``interpolate``) for the initial velocity of a dynamic run."""
        return self._field("velocity")

    @property
    def acceleration(self) -> fem.Function:
        """Acceleration (a reduced subdomain's is expanded here when read)."""
        return self._field("acceleration")

    def defer(self, expansion: Callable[[fem.Function], None], field: str = "u") -> None:
        """Let ``field`` be written by ``expansion`` when it is next read (a reduced model).

        ``field``: ``"u"``, ``"velocity"`` or ``"acceleration"``.
        """
        self._deferred[field] = expansion

    def reduce(
        self,
        modes: int,
        tolerance: float = MODES_TOLERANCE,
        if_cheaper: bool = False,
        eigensolver: str = "block",
        out_of_core: bool = False,
    ) -> Subdomain:
        """Represent this subdomain by a reduced model (Craig-Bampton; docs/solvers.md).

        The solvers then hold it as a small dense matrix over its boundary dofs (those of
        its ties and contact interfaces, kept physical), ``modes`` fixed-interface normal
        modes (the lowest) and one load mode per load pattern (so that a
        quasi-static response is exact). Waves above the last mode kept are not carried.

        Args:
            modes: Number of fixed-interface modes (>= 0; 0: a static reduction; as many as
                its interior dofs or more: every mode, the interior kept whole, for an
                interior of up to ``WHOLE_INTERIOR_LIMIT`` dofs).
            tolerance: The eigensolver's relative tolerance on the modes
                (``||A^-1 M x - x / lambda|| <= tolerance / lambda``). The model is exact
                in whatever basis it finds, so a loose one (0.1-0.5: the higher "modes"
                are Ritz vectors) still carries the dynamics: the paper's bar with m = 320
                kept its force history within 0.65 % at 0.5 and set up a third faster.
            if_cheaper: Keep it whole instead when its reduced block (boundary dofs, modes
                and load modes: dense) would cost more to substitute than its sparse factor,
                priced with this machine's measured rates: a block that is mostly boundary
                (the pin joint's hole blocks) gains nothing.
            eigensolver: How the modes are found: ``"block"`` (a block Lanczos whose every
                solve takes many columns at once) or ``"slepc"`` (SLEPc's Krylov-Schur, one
                column per solve): the same modes, the first 2.5-2.8 times faster at 86k
                interior dofs (docs/solvers.md, "Reduced subdomains").
            out_of_core: Keep its interior's factor on disk (MUMPS out-of-core, in its
                temporary directory): the set-up and the expansions of its full fields read
                it back, no step does; the set-up solves in wide passes, one read each. At
                1/4 of the paper's bar the run's peak memory fell from 4.56 to 2.88 GiB (the
                unreduced w-u: 3.94) for the same set-up time (docs/solvers.md, "The
                interior's factor out of core", "Out of core in wide passes").

        Returns:
            The subdomain, so calls can be chained.
        """
        if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or modes < 0:
            raise InputError(
                f"subdomain {self.name!r}: reduce(modes=...) takes a number of modes >= 0, "
                f"got {modes!r}; e.g. reduce(modes=20)"
            )
        tolerance = arguments.real(tolerance, f"subdomain {self.name!r} reduce(tolerance)")
        if not 0 < tolerance < 1:
            raise InputError(
                f"subdomain {self.name!r}: reduce(tolerance=...) must lie in (0, 1), got "
                f"{tolerance}; e.g. {MODES_TOLERANCE}"
            )
        if eigensolver not in EIGENSOLVERS:
            raise InputError(
                f"subdomain {self.name!r}: reduce(eigensolver={eigensolver!r}) is not one of "
                f"{', '.join(map(repr, EIGENSOLVERS))}; e.g. reduce(modes=20, eigensolver='block')"
            )
        if not isinstance(out_of_core, bool | np.bool_):
            raise InputError(
                f"subdomain {self.name!r}: reduce(out_of_core=...) takes True or False, got "
                f"{out_of_core!r}"
            )
        self.reduction = Reduction(
            int(modes), tolerance, bool(if_cheaper), eigensolver, bool(out_of_core)
        )
        return self

    # -- boundary conditions -------------------------------------------------------------
    def locate_facets(self, where: Region, argument: str = "where") -> np.ndarray:
        """Boundary facets of a region (:data:`dd_contact.arguments.Region`), sorted."""
        return arguments.boundary_facets(self.mesh, where, f"subdomain {self.name!r}: {argument}")

    def fix(
        self,
        where: Region | fem.DirichletBC | Sequence[fem.DirichletBC],
        components: Sequence[int] | None = None,
        value: Value | None = None,
    ) -> Subdomain:
        """Prescribe displacement on a boundary region (a Dirichlet condition).

        Args:
            where: The region: a locator ``x -> bool``, facet indices, a facet MeshTags, or
                ``(meshtags, value)``. Or dolfinx ``DirichletBC`` objects built on :attr:`V` or
                its sub-spaces ``V.sub(i)`` (``components`` and ``value`` then come from
                the conditions; their values are read at every solve, so a ``Constant`` or
                ``Function`` updated between solves takes effect).
            components: Which components (default all three).
            value: A 3-vector (default zero), a callable ``x -> (3, n)`` array, or a
                callable ``(x, t)`` returning a ``(3, n)`` array or a 3-vector, evaluated at
                every solve time (``lambda x, t: (0.0, 0.0, -d(t))`` presses down by d(t)).
                A changing value is a new right-hand side, never a new factorisation.

        Returns:
            The subdomain, so calls can be chained.
        """
        if isinstance(where, fem.DirichletBC) or (
            isinstance(where, Sequence) and where and isinstance(where[0], fem.DirichletBC)
        ):
            bcs = (
                [where]
                if isinstance(where, fem.DirichletBC)
                else cast(Sequence[fem.DirichletBC], where)
            )
            self.prescribed.add_dirichletbcs(bcs)
            return self
        picked = arguments.components(components, f"subdomain {self.name!r} fix(components=...)")
        facets = self.locate_facets(cast(Region, where))  # not DirichletBCs: returned above
        nodes = fem.locate_dofs_topological(self.V, self.mesh.topology.dim - 1, facets)
        nodes = nodes[nodes < self.V.dofmap.index_map.size_local]
        self.prescribed.add_nodes(nodes, picked, value, float(self.time.value))
        return self

    def add_traction(
        self,
        where: Region,
        traction: ufl.core.expr.Expr | Sequence[float] | Callable[[float], Sequence[float]],
        amplitude: Callable[[float], float] | None = None,
    ):
        """Apply a surface traction (force per area) on a boundary region.

        Args:
            where: The region: a locator ``x -> bool``, facet indices, a facet MeshTags, or
                ``(meshtags, value)``.
            traction: A UFL vector expression on this mesh (it may use :attr:`time` or any
                ``fem.Constant``), a 3-vector, or a callable ``t -> 3-vector`` evaluated by
                the solver at every time.
            amplitude: A callable ``t -> number``: the traction is ``amplitude(t) *
                traction``. A traction field that does not change with time is then
                assembled once and scaled at every time (``docs/solvers.md``, "Loads").

        Returns:
            The subdomain, so calls can be chained.
        """
        facets = self.locate_facets(where)
        tags = dolfinx.mesh.meshtags(
            self.mesh, self.mesh.topology.dim - 1, facets, np.ones_like(facets)
        )
        self.tractions.append((tags, self._load_expression(traction, "traction", amplitude)))
        return self

    def set_body_force(
        self,
        force: ufl.core.expr.Expr | Sequence[float] | Callable[[float], Sequence[float]],
        amplitude: Callable[[float], float] | None = None,
    ) -> Subdomain:
        """Body force per volume: a UFL expression, a 3-vector or a callable ``t -> 3-vector``.

        ``amplitude`` (a callable ``t -> number``) makes it ``amplitude(t) * force``, as in
        :meth:`add_traction`.
        """
        self.body_force = self._load_expression(force, "body force", amplitude)
        return self

    def _load_expression(self, value, what: str, amplitude=None) -> ufl.core.expr.Expr:
        argument = f"subdomain {self.name!r} {what}"
        if isinstance(value, ufl.core.expr.Expr):
            expr = arguments.ufl_vector(value, argument)
        elif callable(value):
            expr = fem.Constant(self.mesh, np.zeros(3))
            self._timed.append((expr, value, argument))
        else:
            expr = fem.Constant(self.mesh, arguments.vector(value, argument))
        if amplitude is None:
            self.set_time(float(self.time.value))
            return expr
        if not callable(amplitude):
            raise InputError(
                f"{argument}: amplitude must be a callable t -> number (the load is then "
                f"amplitude(t) * {what}), got {amplitude!r}; e.g. amplitude=lambda t: min(t, 1)"
            )
        scale = fem.Constant(self.mesh, 0.0)
        self._amplitudes.append((scale, amplitude, f"{argument} amplitude"))
        self.set_time(float(self.time.value))
        return scale * expr

    def set_time(self, t: float) -> None:
        """Set :attr:`time` and evaluate the callable loads and amplitudes at ``t``."""
        # dolfinx annotates Constant.value's setter as an array; it takes a number too
        self.time.value = t  # type: ignore[assignment]
        for constant, load, argument in self._timed:
            values = load(t)
            what = f"{argument} (its load callable returned {values!r} at t = {t})"
            constant.value[:] = arguments.vector(values, what)
        for scale, amplitude, argument in self._amplitudes:
            value = amplitude(t)
            what = f"{argument} (its callable returned {value!r} at t = {t})"
            scale.value = arguments.real(value, what)  # type: ignore[assignment]  # as above

    @property
    def time_constants(self) -> tuple[fem.Constant, ...]:
        """The Constants :meth:`set_time` sets.

        :attr:`time`, the load callables' values and the amplitudes: a load that uses none
        of them does not change with time.
        """
        return (self.time, *(c for c, _, _ in self._timed), *(c for c, _, _ in self._amplitudes))

    @property
    def dirichlet(self) -> tuple[np.ndarray, np.ndarray]:
        """Constrained dofs (unrolled, 3 per node) and their values at :attr:`time`.

        Where conditions overlap, the latest wins; ``prescribed.values(t)`` gives the
        values at another time.
        """
        return self.prescribed.dofs, self.prescribed.values(float(self.time.value))

    @property
    def num_dofs(self) -> int:
        """Number of displacement dofs (3 per node)."""
        return self.V.dofmap.index_map.size_local * 3

    @property
    def block(self) -> Block:
        """This subdomain's block of unknowns u in system (14)."""
        block = self.__dict__.get("_block")  # read some 500 times a step: made once per name
        if block is None or block.name != self.name:
            block = self._block = Block("u", self.name)
        return block
