"""Accuracy presets (dd_contact.accuracy): names, what they set, and "balanced" = the default."""

from mpi4py import MPI

import numpy as np
import pytest

from dd_contact import meshes
from dd_contact.accuracy import ACCURACY_PRESETS, contact_wave_time, mesh_size
from dd_contact.errors import InputError
from dd_contact.obstacles import Plane
from dd_contact.paper import verify
from dd_contact.problem import StaticProblem, TransientProblem
from dd_contact.scene import ContactBoundary, Scene
from dd_contact.subdomains import Material, Subdomain


def _block(rho=1.0, contact=True):
    mesh = meshes.box(MPI.COMM_SELF, [0, 0, 0], [1, 0.5, 0.25], [8, 2, 1])
    block = Subdomain(mesh, Material(1.0, 0.25, rho), "block")
    block.fix(lambda x: np.isclose(x[0], 1.0))
    zones = []
    if contact:
        end = block.locate_facets(lambda x: np.isclose(x[0], 0.0))
        zones = [ContactBoundary(block, end, Plane([-0.01, 0, 0], [1, 0, 0]), name="end")]
    return Scene(MPI.COMM_SELF, [block], contacts=zones)


@pytest.mark.parametrize("kind", [StaticProblem, TransientProblem])
def test_a_bad_preset_name_is_refused_with_the_valid_ones(kind):
    args = (0.1,) if kind is TransientProblem else ()
    valid = r"unknown accuracy 'quick'; valid: 'fast', 'balanced', 'reference'"
    with pytest.raises(InputError, match=valid):
        kind(_block(), *args, accuracy="quick")


def test_the_wave_time_is_the_shortest_edge_over_the_p_wave_speed():
    # 8 x 2 x 1 cells on 1 x 0.5 x 0.25: the shortest edge 0.125; c the P-wave speed.
    c = np.sqrt(0.75 / (1.25 * 0.5))
    assert contact_wave_time(_block()) == pytest.approx(0.125 / c, rel=1e-12)
    with pytest.raises(InputError, match="has no contact: give dt"):
        contact_wave_time(_block(contact=False))
    with pytest.raises(InputError, match="no density"):
        contact_wave_time(_block(rho=0.0))
    with pytest.raises(InputError, match="inertia=False"):
        TransientProblem(_block(), inertia=False, accuracy="balanced")


def test_a_step_left_out_needs_a_preset_named():
    # a step from the wave time can be far finer than a slowly loaded scene needs: no default
    with pytest.raises(InputError, match="no time step; give dt, or name an accuracy preset"):
        TransientProblem(_block())
    assert TransientProblem(_block(), 0.01).mass_kind == "consistent"  # "balanced"'s mass


def test_the_presets_set_the_step_and_the_mass_left_out():
    for name, preset in ACCURACY_PRESETS.items():
        problem = TransientProblem(_block(), accuracy=name)
        assert problem.dt == pytest.approx(preset.courant * contact_wave_time(_block()), 1e-12)
        assert problem.mass_kind == preset.mass
        given = TransientProblem(_block(), 0.01, mass="lumped", accuracy=name)
        assert (given.dt, given.mass_kind) == (0.01, "lumped")  # what is given is kept


def test_balanced_is_the_default_bit_for_bit():
    default = verify.bar_impact(n=40, cfl=1.0, comm=MPI.COMM_SELF)
    balanced = verify.bar_impact(n=40, cfl=1.0, comm=MPI.COMM_SELF, accuracy="balanced")
    assert balanced["forces"] == default["forces"]
    assert balanced["energy_ratio"] == default["energy_ratio"]
    # The preset's own step: one wave time, h / c = 1 / 40 (nu = 0, c = 1): the same answer.
    preset = verify.bar_impact(n=40, cfl=None, comm=MPI.COMM_SELF)
    assert preset["dt"] == pytest.approx(0.025, rel=1e-12)
    assert preset["forces"] == pytest.approx(default["forces"], rel=1e-9, abs=1e-15)
    assert StaticProblem(_block()).accuracy == "balanced"


def test_a_builder_taking_the_preset_scales_its_size_near_the_contact():
    assert mesh_size(0.015, "balanced") == 0.015  # "balanced": the size given, bit for bit
    assert mesh_size(0.015, "fast") == pytest.approx(0.03, rel=1e-15)
    assert mesh_size(0.015, "reference") == pytest.approx(0.01, rel=1e-15)
    with pytest.raises(InputError, match="mesh_size: unknown accuracy 'quick'"):
        mesh_size(0.015, "quick")
    # the Hertz scene's builder: "fast" at 0.015 R is the mesh of 0.03 R, the same answer
    fast = verify.hertz(0.015, comm=MPI.COMM_SELF, accuracy="fast")
    coarse = verify.hertz(0.03, comm=MPI.COMM_SELF)
    assert (fast["dofs"], fast["force"]) == (coarse["dofs"], coarse["force"])
