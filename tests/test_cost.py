"""Tests of the operation-count model (dd_contact.cost, method.md section 6)."""

from __future__ import annotations

import dataclasses
import json
from itertools import product

import numpy as np
import pytest

from dd_contact.cost import (
    ALGORITHMS,
    ContactCounts,
    MeshCounts,
    SceneSizes,
    SubdomainCounts,
    compare,
    f1,
    f2,
    f3,
    f4,
    format_table,
    half_bandwidth_structured_hex,
    operation_counts,
    parallelepiped_sizes,
    to_json_dict,
)

# Tiny scene: D_U = 30, B_U = 9 (both subdomains), D_V = 6, D_W = 6, N_TS = 3, alpha = gamma = 2;
# the merged model (FULL, w-u) has D = 57, B = 9.
DU, BU, DV, DW, NTS, ALPHA, GAMMA = 30, 9, 6, 6, 3, 2, 2
D_WHOLE, B_WHOLE = 57, 9

# Kernel values worked out by hand.
F1_6 = 6**3 / 3  # 72
F2_6 = 1.5 * 6**2  # 54
F3_30_9 = 30 * 81 - 2 * 729 / 3  # 2430 - 486 = 1944
F4_30_9 = 3 * 30 * 9  # 810
F3_57_9 = 57 * 81 - 2 * 729 / 3  # 4617 - 486 = 4131
F4_57_9 = 3 * 57 * 9  # 1539


def tiny_scene(
    alpha: int = ALPHA, gamma: int = GAMMA, b_contact: int = BU, b_whole: int = B_WHOLE
) -> SceneSizes:
    return SceneSizes(
        subdomains=(
            SubdomainCounts("Omega1", DU, b_contact),
            SubdomainCounts("Omega2", DU, BU),
        ),
        contacts=(ContactCounts("Gamma_C1", DW, 0, alpha),),
        interface_dofs=DV,
        n_steps=NTS,
        gamma=gamma,
        whole=MeshCounts("Omega", D_WHOLE, b_whole),
    )


def ops(report) -> float:
    return report.gflops_total * 1e9


def rows(report) -> dict[str, tuple]:
    return {
        m.name: (
            m.dofs,
            m.half_bandwidth,
            m.decompositions,
            m.substitutions,
            m.gflops_decomposition * 1e9,
            m.gflops_substitution * 1e9,
        )
        for m in report.meshes
    }


def test_kernels():
    assert f1(6) == pytest.approx(72.0)
    assert f2(6) == pytest.approx(54.0)
    assert f3(30, 9) == pytest.approx(1944.0)
    assert f4(30, 9) == pytest.approx(810.0)
    # a banded matrix of full bandwidth costs as much as a dense one
    assert f3(40, 40) == pytest.approx(f1(40))
    np.testing.assert_allclose(f4(np.array([10, 20]), 3), [90.0, 180.0])


def test_tiny_vwu_table1():
    r = rows(operation_counts(tiny_scene(), "v-w-u"))
    # Omega1 owns the contact: D_W + D_V + 2 N_TS = 6 + 6 + 6 = 18 substitutions
    assert r["Omega1"] == pytest.approx((30, 9, 1, 18, 1944.0, 18 * 810.0))
    # Omega2: D_V + 2 N_TS = 12
    assert r["Omega2"] == pytest.approx((30, 9, 1, 12, 1944.0, 12 * 810.0))
    # Gamma_C1: 1 + alpha = 3 decompositions; (1+alpha) D_V + (N_TS+alpha) + (N_TS+gamma) = 28
    assert r["Gamma_C1"] == pytest.approx((6, None, 3, 28, 3 * 72.0, 28 * 54.0))
    # Gamma_I: 1 + gamma = 3 decompositions, N_TS + gamma = 5 substitutions
    assert r["Gamma_I"] == pytest.approx((6, None, 3, 5, 3 * 72.0, 5 * 54.0))
    total = 2 * F3_30_9 + 30 * F4_30_9 + 3 * F1_6 + 28 * F2_6 + 3 * F1_6 + 5 * F2_6
    assert total == 30402.0
    assert ops(operation_counts(tiny_scene(), "v-w-u")) == pytest.approx(30402.0, rel=1e-12)


def test_tiny_wvu():
    rep = operation_counts(tiny_scene(), "w-v-u")
    r = rows(rep)
    assert r["Omega1"] == pytest.approx((30, 9, 1, 18, 1944.0, 18 * 810.0))
    assert r["Omega2"] == pytest.approx((30, 9, 1, 12, 1944.0, 12 * 810.0))
    # Gamma_I factorised once; D_W + 2 N_TS = 12 substitutions
    assert r["Gamma_I"] == pytest.approx((6, None, 1, 12, 72.0, 12 * 54.0))
    # Gamma_C1: 1 + gamma decompositions, N_TS + gamma solves for w
    assert r["Gamma_C1"] == pytest.approx((6, None, 3, 5, 3 * 72.0, 5 * 54.0))
    total = 2 * F3_30_9 + 30 * F4_30_9 + F1_6 + 12 * F2_6 + 3 * F1_6 + 5 * F2_6
    assert total == 29394.0
    assert ops(rep) == pytest.approx(total, rel=1e-12)


def test_tiny_wu():
    rep = operation_counts(tiny_scene(), "w-u")
    r = rows(rep)
    # merged model: factorised once, D_W + 2 N_TS = 12 substitutions
    assert r["Omega"] == pytest.approx((57, 9, 1, 12, 4131.0, 12 * 1539.0))
    assert r["Gamma_C1"] == pytest.approx((6, None, 3, 5, 3 * 72.0, 5 * 54.0))
    total = F3_57_9 + 12 * F4_57_9 + 3 * F1_6 + 5 * F2_6
    assert total == 23085.0
    assert ops(rep) == pytest.approx(total, rel=1e-12)


def test_tiny_vu():
    rep = operation_counts(tiny_scene(), "v-u")
    r = rows(rep)
    # contact subdomain: 1 + alpha = 3 factorisations;
    # (1+alpha) D_V + (N_TS+alpha) + (N_TS+gamma) = 18 + 5 + 5 = 28 substitutions
    assert r["Omega1"] == pytest.approx((30, 9, 3, 28, 3 * 1944.0, 28 * 810.0))
    assert r["Omega2"] == pytest.approx((30, 9, 1, 12, 1944.0, 12 * 810.0))
    assert r["Gamma_I"] == pytest.approx((6, None, 3, 5, 3 * 72.0, 5 * 54.0))
    assert "Gamma_C1" not in r
    total = 4 * F3_30_9 + 40 * F4_30_9 + 3 * F1_6 + 5 * F2_6
    assert total == 40662.0
    assert ops(rep) == pytest.approx(total, rel=1e-12)


def test_tiny_full_and_percent():
    rep = operation_counts(tiny_scene(), "FULL")
    assert rows(rep)["Omega"] == pytest.approx((57, 9, 3, 5, 3 * 4131.0, 5 * 1539.0))
    full = 3 * F3_57_9 + 5 * F4_57_9
    assert full == 20088.0
    assert ops(rep) == pytest.approx(full, rel=1e-12)

    reports = compare(tiny_scene())
    assert tuple(reports) == ALGORITHMS
    assert reports["FULL"].percent_of_full == 100.0
    expected = {"v-w-u": 30402.0, "w-v-u": 29394.0, "w-u": 23085.0, "v-u": 40662.0}
    for alg, total in expected.items():
        assert reports[alg].percent_of_full == pytest.approx(100.0 * total / full, rel=1e-12)


def test_multiple_contacts_couple_in_wvu_and_wu():
    scene = SceneSizes(
        subdomains=(SubdomainCounts("A", DU, BU), SubdomainCounts("B", DU, BU)),
        contacts=(ContactCounts("CA", DW, 0, 2), ContactCounts("CB", DW, 1, 3)),
        interface_dofs=DV,
        n_steps=NTS,
        gamma=4,
        whole=MeshCounts("Omega", D_WHOLE, B_WHOLE),
    )
    # v-w-u: decoupled blocks, each with its own alpha
    r = rows(operation_counts(scene, "v-w-u"))
    assert r["CA"][2:4] == (3, 3 * 6 + 5 + 7)
    assert r["CB"][2:4] == (4, 4 * 6 + 6 + 7)
    # w-v-u and w-u: one dense block of 12 dofs, 1 + gamma = 5 factorisations, N_TS + gamma = 7
    for alg in ("w-v-u", "w-u"):
        r = rows(operation_counts(scene, alg))
        assert r["CA+CB"] == pytest.approx((12, None, 5, 7, 5 * 12**3 / 3, 7 * 1.5 * 144))
    assert rows(operation_counts(scene, "w-v-u"))["Gamma_I"][3] == 12 + 2 * NTS


def test_half_bandwidth_paper_bar():
    assert half_bandwidth_structured_hex(400, 100, 10) == 3372
    assert 3 * ((100 + 1) * (10 + 1) + (10 + 1) + 1) + 3 == 3372


@pytest.mark.parametrize("nx,ny,nz", [(1, 1, 1), (3, 2, 4), (4, 5, 2), (2, 3, 1), (5, 1, 3)])
def test_half_bandwidth_brute_force(nx, ny, nz):
    # number nodes x slowest, z fastest, interleave 3 dofs; scan every element's dof pairs
    node = np.arange((nx + 1) * (ny + 1) * (nz + 1)).reshape(nx + 1, ny + 1, nz + 1)
    b = 0
    for i, j, k in product(range(nx), range(ny), range(nz)):
        nodes = node[i : i + 2, j : j + 2, k : k + 2].ravel()
        dofs = (3 * nodes[:, None] + np.arange(3)).ravel()
        b = max(b, int(dofs.max() - dofs.min()) + 1)
    assert half_bandwidth_structured_hex(nx, ny, nz) == b
    assert b == 3 * ((ny + 2) * (nz + 1) + 2)


def test_parallelepiped_sizes():
    s = parallelepiped_sizes()
    assert s.whole.dofs == 401 * 101 * 11 * 3 == 1_336_533
    assert s.whole.half_bandwidth == 3372
    assert [sd.dofs for sd in s.subdomains] == [201 * 101 * 11 * 3] * 2 == [669_933] * 2
    assert [sd.half_bandwidth for sd in s.subdomains] == [3372, 3372]
    assert s.interface_dofs == 1111 * 3 == 3333
    assert s.contacts[0].dofs == 3333 and s.contacts[0].subdomain == 0
    assert s.contacts[0].alpha == s.gamma == 20000 and s.n_steps == 10000
    s19 = parallelepiped_sizes(split=(1, 9))
    assert [sd.dofs for sd in s19.subdomains] == [41 * 1111 * 3, 361 * 1111 * 3]
    with pytest.raises(ValueError):
        parallelepiped_sizes(split=(1, 6))


def test_paper_bar_full_and_ratios():
    reports = compare(parallelepiped_sizes())
    d, b = 1_336_533, 3372
    full = 20001 * (d * b**2 - 2 * b**3 / 3) + 30000 * 3 * d * b
    assert reports["FULL"].gflops_total == pytest.approx(full / 1e9, rel=1e-12)
    assert reports["FULL"].percent_of_full == 100.0
    # the decomposed orders with contact interfaces are below 1 % of FULL on the paper's bar
    for alg in ("v-w-u", "w-v-u", "w-u"):
        assert reports[alg].percent_of_full < 1.0
    # w-u: f3 + f4 (D_W + 2 N_TS) on the bar, f1 (1+gamma) + f2 (N_TS+gamma) on the contact
    wu = f3(d, b) + 23333 * f4(d, b) + 20001 * f1(3333) + 30000 * f2(3333)
    assert reports["w-u"].gflops_total == pytest.approx(wu / 1e9, rel=1e-12)


def full_total(gamma: int) -> float:
    return operation_counts(tiny_scene(alpha=gamma, gamma=gamma), "FULL").gflops_total


def test_full_linear_in_gamma():
    g = [full_total(x) for x in (10, 20, 30, 1000)]
    assert g[2] - 2 * g[1] + g[0] == pytest.approx(0.0, abs=1e-18)
    slope = (F3_57_9 + F4_57_9) / 1e9
    assert (g[1] - g[0]) / 10 == pytest.approx(slope, rel=1e-9)
    assert (g[3] - g[0]) / 990 == pytest.approx(slope, rel=1e-9)
    # the same on the paper's bar
    b = [compare(parallelepiped_sizes(changes=c))["FULL"].gflops_total for c in (100, 200, 300)]
    assert (b[2] - 2 * b[1] + b[0]) / b[1] == pytest.approx(0.0, abs=1e-12)


def per_change(alg: str, **kw) -> float:
    """Cost of one more contact change (alpha and gamma both + 1), in operations."""
    lo = operation_counts(tiny_scene(alpha=5, gamma=5, **kw), alg)
    hi = operation_counts(tiny_scene(alpha=6, gamma=6, **kw), alg)
    return ops(hi) - ops(lo)


def test_wu_per_change_independent_of_bandwidth():
    costs = [per_change("w-u", b_contact=bc, b_whole=bw) for bc, bw in [(3, 3), (9, 9), (20, 40)]]
    assert costs == pytest.approx([F1_6 + F2_6] * 3, rel=1e-12)  # 126 each


def test_only_vu_per_change_grows_with_contact_bandwidth():
    bandwidths = (3, 9, 20)
    for alg in ("FULL", "v-w-u", "w-v-u", "w-u"):
        costs = [per_change(alg, b_contact=bc) for bc in bandwidths]
        assert max(costs) - min(costs) == pytest.approx(0.0, abs=1e-6), alg
    vu = [per_change("v-u", b_contact=bc) for bc in bandwidths]
    assert vu[0] < vu[1] < vu[2]
    # v-u per change: f3 + f4 (D_V + 2) on the contact subdomain, f1 + f2 on the interface
    for bc, cost in zip(bandwidths, vu, strict=True):
        expected = f3(DU, bc) + f4(DU, bc) * (DV + 2) + F1_6 + F2_6
        assert cost == pytest.approx(expected, rel=1e-12)
    # v-w-u per change: f1 + f2 (D_V + 2) on Gamma_C, f1 + f2 on Gamma_I
    assert per_change("v-w-u") == pytest.approx(F1_6 + F2_6 * (DV + 2) + F1_6 + F2_6, rel=1e-12)


def test_json_and_table():
    reports = compare(tiny_scene())
    js = to_json_dict(reports)
    assert set(js) == set(ALGORITHMS)
    assert js["FULL"]["percent_of_full"] == 100.0
    assert js["v-w-u"]["gflops_total"] == pytest.approx(30402e-9, rel=1e-12)
    mesh = js["v-w-u"]["meshes"][0]
    assert set(mesh) == {
        "name",
        "dofs",
        "half_bandwidth",
        "decompositions",
        "substitutions",
        "gflops_decomposition",
        "gflops_substitution",
    }
    assert (mesh["name"], mesh["dofs"], mesh["substitutions"]) == ("Omega1", 30, 18)
    assert json.loads(json.dumps(js))["w-u"]["meshes"][1]["half_bandwidth"] is None
    table = format_table(reports)
    assert table.count("% of FULL") == 5
    assert "v-w-u: 3.0402e-05 GFLOP" in table
    assert "dense" in table


def test_validation():
    with pytest.raises(ValueError):  # gamma below max(alpha)
        tiny_scene(alpha=3, gamma=2)
    with pytest.raises(ValueError):  # half-bandwidth larger than the matrix
        SubdomainCounts("x", 5, 6)
    with pytest.raises(ValueError):
        operation_counts(tiny_scene(), "u-v-w")
    no_interface = dataclasses.replace(tiny_scene(), interface_dofs=None)
    assert tuple(compare(no_interface)) == ("FULL", "w-u")
    with pytest.raises(ValueError):
        operation_counts(no_interface, "v-w-u")
    assert ops(operation_counts(no_interface, "w-u")) == pytest.approx(23085.0, rel=1e-12)
