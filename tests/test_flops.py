"""Tests of the operation-count model (dd_contact.paper.flops, method.md section 6)."""

from __future__ import annotations

import dataclasses
import json
from itertools import permutations, product
from pathlib import Path

import numpy as np
import pytest

from dd_contact.paper.flops import (
    ALGORITHMS,
    STEPS_SWEEP,
    ContactCounts,
    MeshCounts,
    PinJointLayout,
    SceneSizes,
    SubdomainCounts,
    compare,
    f1,
    f2,
    f3,
    f4,
    format_table,
    half_bandwidth_box,
    half_bandwidth_structured_hex,
    load_scene,
    matrix_half_bandwidth,
    operation_counts,
    parallelepiped_sizes,
    parallelepiped_studies,
    pin_joint_mesh_counts,
    pin_joint_sizes,
    pin_joint_studies,
    plot_study,
    rcm_half_bandwidth,
    scene_from_dict,
    scene_studies,
    scene_to_dict,
    to_json_dict,
    write_studies,
)
from dd_contact.paper.flops import paper as flops_paper
from dd_contact.paper.flops import studies as flops_studies

DOCS = Path(__file__).resolve().parents[1] / "docs"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

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


# The hand counts below are the paper's Table 1 reading (u_hat and u: two subdomain
# substitutions per step), the model's substitutions_per_step=2; the default, one per step
# (Tables 2 and 3), is checked against them in test_one_substitution_per_step.
def tiny_scene(
    alpha: int = ALPHA,
    gamma: int = GAMMA,
    b_contact: int = BU,
    b_whole: int = B_WHOLE,
    per_step: int = 2,
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
        substitutions_per_step=per_step,
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
    # w-u: f3 + f4 (D_W + N_TS) on the bar, f1 (1+gamma) + f2 (N_TS+gamma) on the contact
    wu = f3(d, b) + 13333 * f4(d, b) + 20001 * f1(3333) + 30000 * f2(3333)
    assert reports["w-u"].gflops_total == pytest.approx(wu / 1e9, rel=1e-12)
    # the paper's Table 3: w-u 442,523 GFLOP; v-w-u, w-v-u, w-u 0.600, 0.153, 0.146 % of FULL
    assert reports["w-u"].gflops_total == pytest.approx(442_523, rel=5e-3)
    for alg, percent in (("v-w-u", 0.600), ("w-v-u", 0.153), ("w-u", 0.146)):
        assert reports[alg].percent_of_full == pytest.approx(percent, rel=5e-3), alg
    # the Table 1 reading (u_hat and u: two subdomain substitutions per step)
    table1 = compare(dataclasses.replace(parallelepiped_sizes(), substitutions_per_step=2))
    wu1 = wu + 10000 * f4(d, b)
    assert table1["w-u"].gflops_total == pytest.approx(wu1 / 1e9, rel=1e-12)
    assert table1["w-u"].percent_of_full == pytest.approx(0.190, abs=5e-4)


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


# --------------------------------------------------------------------------- D_V^(k)

# Three subdomains tied to different parts of a D_V = 6 interface, two contact interfaces:
#   A: D_U = 30, B_U = 9, tied to 4 interface dofs, owns CA (D_W = 6, alpha = 2)
#   B: D_U = 30, B_U = 9, tied to the whole interface (interface_dofs=None -> 6)
#   C: D_U = 20, B_U = 5, tied to 2 interface dofs, owns CC (D_W = 3, alpha = 1)
#   N_TS = 2, gamma = 3 (max alpha = 2 <= 3 <= 3 = sum alpha); merged model D = 70, B = 9.
F3_20_5 = 20 * 25 - 2 * 125 / 3  # 416.667
F4_20_5 = 3 * 20 * 5  # 300
F1_3, F2_3 = 9.0, 13.5
F1_9, F2_9 = 243.0, 121.5
F3_70_9, F4_70_9 = 70 * 81 - 486, 3 * 70 * 9  # 5184, 1890


def three_scene() -> SceneSizes:
    return SceneSizes(
        subdomains=(
            SubdomainCounts("A", 30, 9, 4),
            SubdomainCounts("B", 30, 9),
            SubdomainCounts("C", 20, 5, 2),
        ),
        contacts=(ContactCounts("CA", 6, 0, 2), ContactCounts("CC", 3, 2, 1)),
        interface_dofs=6,
        n_steps=2,
        gamma=3,
        whole=MeshCounts("Omega", 70, 9),
        substitutions_per_step=2,  # hand counts of the Table 1 reading, as tiny_scene
    )


def test_three_vwu_uses_tied_interface_dofs():
    s = three_scene()
    assert [s.tied_dofs(k) for k in range(3)] == [4, 6, 2]
    rep = operation_counts(s, "v-w-u")
    r = rows(rep)
    # subdomains: D_W + D_V^(k) + 2 N_TS substitutions
    assert r["A"] == pytest.approx((30, 9, 1, 6 + 4 + 4, F3_30_9, 14 * F4_30_9))
    assert r["B"] == pytest.approx((30, 9, 1, 6 + 4, F3_30_9, 10 * F4_30_9))
    assert r["C"] == pytest.approx((20, 5, 1, 3 + 2 + 4, F3_20_5, 9 * F4_20_5))
    # contact: (1+alpha) D_V^(k) + (N_TS + alpha) + (N_TS + gamma)
    assert r["CA"] == pytest.approx((6, None, 3, 3 * 4 + 4 + 5, 3 * F1_6, 21 * F2_6))
    assert r["CC"] == pytest.approx((3, None, 2, 2 * 2 + 3 + 5, 2 * F1_3, 12 * F2_3))
    assert r["Gamma_I"] == pytest.approx((6, None, 4, 5, 4 * F1_6, 5 * F2_6))
    total = (
        2 * F3_30_9 + F3_20_5 + 24 * F4_30_9 + 9 * F4_20_5
        + 3 * F1_6 + 21 * F2_6 + 2 * F1_3 + 12 * F2_3 + 4 * F1_6 + 5 * F2_6
    )  # fmt: skip
    assert total == pytest.approx(28532 + 2 / 3, rel=1e-15)
    assert ops(rep) == pytest.approx(total, rel=1e-12)


def test_three_wvu_wu_vu():
    s = three_scene()
    r = rows(operation_counts(s, "w-v-u"))
    assert r["A"][3] == 14 and r["B"][3] == 10 and r["C"][3] == 9
    # Gamma_I once; sum D_W + 2 N_TS = 9 + 4 substitutions
    assert r["Gamma_I"] == pytest.approx((6, None, 1, 13, F1_6, 13 * F2_6))
    # all w coupled: one 9-dof block, 1 + gamma factorisations, N_TS + gamma solves
    assert r["CA+CC"] == pytest.approx((9, None, 4, 5, 4 * F1_9, 5 * F2_9))
    r = rows(operation_counts(s, "w-u"))
    assert r["Omega"] == pytest.approx((70, 9, 1, 13, F3_70_9, 13 * F4_70_9))
    assert r["CA+CC"] == pytest.approx((9, None, 4, 5, 4 * F1_9, 5 * F2_9))
    r = rows(operation_counts(s, "v-u"))
    # A: 1 + alpha = 3 factorisations; (1+alpha) D_V^A + (N_TS+alpha) + (N_TS+gamma) = 12+4+5
    assert r["A"] == pytest.approx((30, 9, 3, 21, 3 * F3_30_9, 21 * F4_30_9))
    assert r["B"] == pytest.approx((30, 9, 1, 10, F3_30_9, 10 * F4_30_9))
    # C: 2 factorisations; 2 * 2 + 3 + 5 = 12
    assert r["C"] == pytest.approx((20, 5, 2, 12, 2 * F3_20_5, 12 * F4_20_5))
    assert r["Gamma_I"] == pytest.approx((6, None, 4, 5, 4 * F1_6, 5 * F2_6))
    assert rows(operation_counts(s, "FULL"))["Omega"] == pytest.approx(
        (70, 9, 4, 5, 4 * F3_70_9, 5 * F4_70_9)
    )


def test_tied_dofs_validation():
    assert three_scene().tied_dofs(1) == 6
    with pytest.raises(ValueError, match="interface_dofs 7 > interface dofs 6"):
        dataclasses.replace(
            three_scene(),
            subdomains=(SubdomainCounts("A", 30, 9, 7), *three_scene().subdomains[1:]),
        )
    with pytest.raises(ValueError, match="tied to an interface, but there is none"):
        dataclasses.replace(three_scene(), interface_dofs=None)
    untied = SceneSizes(
        (SubdomainCounts("A", 30, 9, 0), SubdomainCounts("B", 30, 9)),
        (ContactCounts("CA", 6, 0, 2),),
        6,
        NTS,
        2,
        MeshCounts("Omega", D_WHOLE, B_WHOLE),
        substitutions_per_step=2,
    )
    # an untied contact subdomain: no D_V columns anywhere, P_CD = 0
    r = rows(operation_counts(untied, "v-w-u"))
    assert r["A"][3] == 6 + 0 + 2 * NTS
    assert r["CA"][3] == 0 + (NTS + 2) + (NTS + 2)


def test_wu_independent_of_subdomain_bandwidths():
    # w-u uses only the merged model: the subdomains' own bandwidths never enter
    totals = [ops(operation_counts(tiny_scene(b_contact=bc), "w-u")) for bc in (1, 5, 9, 30)]
    assert totals == pytest.approx([23085.0] * 4, rel=1e-12)


# --------------------------------------------------------------------------- bandwidths


@pytest.mark.parametrize("dims", [(4, 2, 3), (1, 5, 2), (6, 6, 1), (2, 3, 7)])
def test_half_bandwidth_box_is_best_axis_order(dims):
    best = min(half_bandwidth_structured_hex(*p) for p in permutations(dims))
    assert half_bandwidth_box(*dims) == best
    _, b, c = sorted(dims, reverse=True)
    assert best == 3 * ((b + 2) * (c + 1) + 2)


def test_split_changes_contact_subdomain_bandwidth():
    # 1:9 -> Omega1 is 40 x 100 x 10, numbered y slowest: 3 ((40 + 2) 11 + 2) = 1392
    s19 = parallelepiped_sizes(split=(1, 9))
    assert [sd.half_bandwidth for sd in s19.subdomains] == [1392, 3372]
    assert 3 * (42 * 11 + 2) == 1392
    # 2:8 -> 80 x 100 x 10: 3 (82 * 11 + 2) = 2712; 3:7 -> 120 layers, x slowest again
    assert parallelepiped_sizes(split=(2, 8)).subdomains[0].half_bandwidth == 2712
    assert parallelepiped_sizes(split=(3, 7)).subdomains[0].half_bandwidth == 3372


def box_pattern(nx: int, ny: int, nz: int):
    """Dof pattern (3 dofs per node, x slowest) of a structured hexahedral box."""
    from scipy.sparse import coo_array

    xyz, hexes = flops_paper._box_mesh((nx, ny, nz), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    dofs = (3 * hexes[:, :, None] + np.arange(3)).reshape(len(hexes), -1)
    rows_ = np.repeat(dofs, dofs.shape[1], axis=1).ravel()
    cols = np.tile(dofs, (1, dofs.shape[1])).ravel()
    n = 3 * len(xyz)
    return coo_array((np.ones(rows_.size), (rows_, cols)), shape=(n, n)).tocsr(), xyz, hexes


def test_matrix_and_rcm_half_bandwidth():
    a, _, _ = box_pattern(5, 3, 2)
    assert matrix_half_bandwidth(a) == half_bandwidth_structured_hex(5, 3, 2) == 3 * (5 * 3 + 2)
    perm = np.random.default_rng(1).permutation(a.shape[0])
    shuffled = a[perm][:, perm]
    assert matrix_half_bandwidth(shuffled) > 3 * matrix_half_bandwidth(a)
    assert rcm_half_bandwidth(shuffled) <= 2 * matrix_half_bandwidth(a)
    # a path graph in random order: RCM restores a tridiagonal matrix
    n = 50
    p = np.random.default_rng(2).permutation(n)
    path = np.zeros((n, n))
    path[p[:-1], p[1:]] = path[p[1:], p[:-1]] = 1.0
    assert matrix_half_bandwidth(path) > 10
    assert rcm_half_bandwidth(path) == 2
    assert matrix_half_bandwidth(np.zeros((3, 3))) == 1
    with pytest.raises(ValueError, match="square"):
        matrix_half_bandwidth(np.zeros((2, 3)))


def test_best_numbering_on_a_box_is_the_structured_one():
    # the candidate numberings used for the pin-joint plate find the natural numbering on a box
    for dims in [(6, 3, 2), (3, 6, 2), (5, 5, 1)]:
        _, xyz, hexes = box_pattern(*dims)
        assert flops_paper._best_half_bandwidth(xyz, hexes) == half_bandwidth_box(*dims)


# --------------------------------------------------------------------------- pin joint

SMALL = PinJointLayout(n_holes=3, n_circumferential=2, n_radial=3, n_layers=1, n_length=4)


def test_pin_joint_counts_small_by_hand():
    m = pin_joint_mesh_counts(SMALL)
    # hole block: 4c = 8 ring positions x (r+1) = 4 radial x (t+1) = 2 layers
    assert m["hole_block_nodes"] == 8 * 4 * 2 == 64 and m["hole_block_hexahedra"] == 8 * 3 * 1
    # grip: g = 3 * 2 = 6 across, 4 along, 1 layer
    assert m["grip_nodes"] == 7 * 5 * 2 and m["grip_hexahedra"] == 6 * 4
    # plate: 3 blocks of 32 planar nodes, 2 shared sides of 3 nodes, grip adds 7 x 4 rows
    assert m["plate_nodes"] == (3 * 32 - 2 * 3 + 7 * 4) * 2 == 236
    assert m["plate_hexahedra"] == 3 * 24 + 24 == 96
    assert (m["nodes"], m["hexahedra"], m["dofs"]) == (472, 192, 1416)
    # the merged numpy mesh agrees
    xyz, hexes = flops_paper._plate_mesh(SMALL)
    assert (len(xyz), len(hexes)) == (236, 96)
    assert len(np.unique(hexes)) == 236
    # contact: the hole surface, 8 x 1 quads, 8 x 2 nodes
    assert (m["contact_quads"], m["contact_nodes"], m["contact_dofs"]) == (8, 16, 48)
    # interface per plate: long cut 7 node columns + 2 short cuts of 3 columns sharing one
    # with the long cut -> 11 columns x 2 layers of nodes; both plates
    assert m["interface_nodes"] == 2 * 11 * 2 and m["interface_dofs"] == 132
    assert m["interface_quads"] == 2 * (2 * 2 + 6)
    # tied: end block top (3) + one side (2 more) = 5 columns; inner 3 + 2 + 2 = 7; grip 7
    assert m["tied_dofs_end_block"] == 3 * 5 * 2
    assert m["tied_dofs_inner_block"] == 3 * 7 * 2
    assert m["tied_dofs_grip"] == 3 * 7 * 2


@pytest.mark.parametrize("c,r,t", [(2, 3, 1), (3, 2, 2), (1, 4, 3)])
def test_hole_block_zigzag_bandwidths(c, r, t):
    lay = PinJointLayout(n_holes=1, n_circumferential=c, n_radial=r, n_layers=t, n_length=2)
    _, hexes = flops_paper._hole_block_mesh(lay, 0)
    n_ring = 4 * c
    zig = [0]
    lo, hi = 1, n_ring - 1
    while len(zig) < n_ring:
        zig.append(lo)
        lo += 1
        if len(zig) < n_ring:
            zig.append(hi)
            hi -= 1
    pos = np.empty(n_ring, dtype=np.int64)
    pos[zig] = np.arange(n_ring)
    a, b, lay_ = np.meshgrid(np.arange(n_ring), np.arange(r + 1), np.arange(t + 1), indexing="ij")
    ring_slowest = ((pos[a] * (r + 1) + b) * (t + 1) + lay_).ravel()
    radial_slowest = ((b * n_ring + pos[a]) * (t + 1) + lay_).ravel()
    b_ring = flops_paper._span_half_bandwidth(ring_slowest, hexes, 3)
    b_radial = flops_paper._span_half_bandwidth(radial_slowest, hexes, 3)
    assert b_ring == 3 * ((2 * r + 3) * (t + 1) + 2)
    assert b_radial == 3 * ((4 * c + 2) * (t + 1) + 2)
    assert pin_joint_mesh_counts(lay)["hole_block_half_bandwidth"] == min(b_ring, b_radial)


def test_pin_joint_default_sizes():
    m = pin_joint_mesh_counts()
    # comparable to the paper's 173,250 hexahedra and 197,472 nodes
    assert m["hexahedra"] == 2 * 8 * (5 * 4 * 16 * 16 + 80 * 72) == 174_080
    assert m["nodes"] == 2 * 9 * (20 * 16 * 17 - 4 * 17 + 81 * 72) == 201_672
    assert abs(m["hexahedra"] / 173_250 - 1) < 0.01 and abs(m["nodes"] / 197_472 - 1) < 0.03
    assert m["dofs"] == 605_016
    assert m["hole_block_dofs"] == 3 * 64 * 17 * 9 == 29_376
    assert m["hole_block_half_bandwidth"] == 3 * (35 * 9 + 2) == 951
    assert m["grip_dofs"] == 3 * 81 * 73 * 9 == 159_651
    assert m["grip_half_bandwidth"] == 3 * (74 * 9 + 2) == 2004
    assert m["contact_dofs"] == 3 * 64 * 9 == 1728
    assert m["interface_dofs"] == 2 * 3 * 145 * 9 == 7830
    assert (m["tied_dofs_end_block"], m["tied_dofs_inner_block"], m["tied_dofs_grip"]) == (
        3 * 33 * 9,
        3 * 49 * 9,
        3 * 81 * 9,
    )
    # best of the four frontal numberings of a plate (regression value; the grip alone is 2004)
    assert m["half_bandwidth"] == m["plate_half_bandwidth"] == 5088


def test_pin_joint_sizes_structure():
    s = pin_joint_sizes(3)
    assert len(s.subdomains) == 12 and s.interface_dofs == 7830
    assert [sd.name for sd in s.subdomains[:6]] == [*(f"U-hole{i}" for i in range(1, 6)), "U-grip"]
    # contact order: pin 1 upper, pin 1 lower, pin 2 upper
    assert [c.subdomain for c in s.contacts] == [0, 6, 1]
    assert all(c.alpha == s.gamma == 20000 for c in s.contacts)
    assert s.whole == MeshCounts("Omega (both plates)", 605_016, 5088)
    # v-w-u on a contact interface: (1 + alpha) D_V^(k) with the end block's 891 tied dofs
    r = rows(operation_counts(s, "v-w-u"))
    assert r["Gamma_C U-hole1"][3] == 20001 * 891 + 30000 + 30000
    for bad in (0, 11):
        with pytest.raises(ValueError, match="active_holes"):
            pin_joint_sizes(bad)


def test_pin_joint_paper_finding():
    """Few holes in contact: w-v-u and w-u cheapest; many: v-w-u cheapest (method.md 7.2)."""
    two = {a: r.gflops_total for a, r in compare(pin_joint_sizes(2)).items()}
    ten = {a: r.gflops_total for a, r in compare(pin_joint_sizes(10)).items()}
    assert sorted(two, key=two.get)[:2] == ["w-v-u", "w-u"]
    assert min(ten, key=ten.get) == "v-w-u"
    pct = {a: r.percent_of_full for a, r in compare(pin_joint_sizes(10)).items()}
    assert pct["v-w-u"] == pytest.approx(1.481, abs=1e-3)


# --------------------------------------------------------------------------- scene files


def test_scene_round_trip_and_example_file():
    for sizes in (three_scene(), parallelepiped_sizes(), pin_joint_sizes(4)):
        back = scene_from_dict(json.loads(json.dumps(scene_to_dict(sizes))))
        assert back == sizes
    example = load_scene(DOCS / "scene_example.json")
    assert to_json_dict(compare(example)) == to_json_dict(compare(parallelepiped_sizes()))


def minimal_scene() -> dict:
    return {
        "n_steps": 3,
        "gamma": 2,
        "interface": {"dofs": 6},
        "subdomains": [
            {"name": "Omega1", "dofs": 30, "half_bandwidth": 9},
            {"name": "Omega2", "dofs": 30, "half_bandwidth": 9},
        ],
        "contacts": [{"dofs": 6, "subdomain": "Omega1", "alpha": 2}],
        "whole": {"dofs": 57, "half_bandwidth": 9},
    }


def test_scene_from_dict_defaults():
    s = scene_from_dict(minimal_scene())
    assert s == tiny_scene(per_step=1)
    # one substitution per step: 2 N_TS fewer subdomain substitutions than Table 1's 30402
    assert ops(operation_counts(s, "v-w-u")) == pytest.approx(30402.0 - 6 * 810.0, rel=1e-12)
    table1 = scene_from_dict({**minimal_scene(), "substitutions_per_step": 2})
    assert table1 == tiny_scene()
    assert ops(operation_counts(table1, "v-w-u")) == pytest.approx(30402.0, rel=1e-12)
    with pytest.raises(ValueError, match=r"substitutions_per_step must be 1 .* or 2"):
        scene_from_dict({**minimal_scene(), "substitutions_per_step": 3})
    data = minimal_scene()
    del data["whole"]
    data["contacts"][0]["subdomain"] = 0
    s = scene_from_dict(data)
    # default merged model: summed dofs, largest subdomain bandwidth
    assert (s.whole.dofs, s.whole.half_bandwidth) == (60, 9)
    assert s.contacts[0].subdomain == 0 and s.contacts[0].name == "Gamma_C1"
    del data["interface"]
    assert tuple(compare(scene_from_dict(data))) == ("FULL", "w-u")


def _edit(path: str, value):
    data = minimal_scene()
    *parents, last = path.split("/")
    obj = data
    for key in parents:
        obj = obj[int(key)] if key.isdigit() else obj[key]
    if value is KeyError:
        del obj[last]
    else:
        obj[last] = value
    return data


@pytest.mark.parametrize(
    "path,value,message",
    [
        ("gamma", KeyError, r"scene: missing key 'gamma'"),
        ("subdomains/1/dofs", KeyError, r"subdomains\[1\]: missing key 'dofs'"),
        ("subdomains/0/dofs", -5, r"subdomains\[0\]\.dofs must be a positive integer, got -5"),
        ("n_steps", -1, r"n_steps must be a non-negative integer, got -1"),
        ("contacts/0/alpha", 1.5, r"contacts\[0\]\.alpha must be a non-negative integer"),
        ("contacts/0/subdomain", "Omega3", r"'Omega3' is not a subdomain \(known: Omega1, Omega2"),
        ("contacts/0/subdomain", 2, r"index 2 is not a subdomain \(0\.\.1"),
        ("subdomains/0/dof", 3, r"subdomains\[0\]: unknown key 'dof'"),
        ("subdomains/0/half_bandwidth", 31, r"half_bandwidth 31 > dofs 30"),
        ("subdomains/0/interface_dofs", 7, r"interface_dofs 7 > interface dofs 6"),
        ("gamma", 5, r"max\(alpha\) <= gamma <= sum\(alpha\)"),
        ("subdomains", [], r"subdomains must be a non-empty list"),
        ("interface", {"dofs": 0}, r"interface\.dofs must be a positive integer"),
    ],
)
def test_scene_validation(path, value, message):
    with pytest.raises(ValueError, match=message):
        scene_from_dict(_edit(path, value))


def test_load_scene_bad_json(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"n_steps": 1,')
    with pytest.raises(ValueError, match=r"bad\.json: not valid JSON: .*line 1"):
        load_scene(bad)
    bad.write_text("[1, 2]")
    with pytest.raises(ValueError, match="expected a JSON object, got list"):
        load_scene(bad)


# --------------------------------------------------------------------------- studies


def test_parallelepiped_studies_values():
    studies = {s.name: s for s in parallelepiped_studies()}
    assert list(studies) == ["bar_steps", "bar_split", "bar_changes", "bar_contact_elements"]
    steps = studies["bar_steps"]
    assert steps.x == STEPS_SWEEP and (steps.xscale, steps.yscale) == ("log", "log")
    i = STEPS_SWEEP.index(100)
    ref = compare(parallelepiped_sizes(steps=100, changes=200))
    for alg in ALGORITHMS:
        assert steps.percent_of_full[alg][i] == pytest.approx(ref[alg].percent_of_full, rel=1e-12)
    # at the paper's point the study ends on the Table-2 numbers
    bar = compare(parallelepiped_sizes())
    assert steps.percent_of_full["w-u"][-1] == pytest.approx(bar["w-u"].percent_of_full)
    split = studies["bar_split"]
    assert split.xticklabels == tuple(f"{a}:{10 - a}" for a in range(1, 10))
    assert split.extra["contact_subdomain_half_bandwidth"][:3] == (1392, 2712, 3372)
    assert split.percent_of_full["v-u"][4] == pytest.approx(bar["v-u"].percent_of_full)
    contact = studies["bar_contact_elements"]
    assert contact.x == (10, 40, 90, 250, 490, 1000, 1960, 4000)
    assert contact.extra["contact_dofs"][5] == 3333
    # v-u has no contact mesh: flat in the contact-element study
    assert len({round(v, 9) for v in contact.percent_of_full["v-u"]}) == 1
    # an uneven nx skips the splits that do not divide it
    odd = parallelepiped_studies(elements=(30, 4, 2), interface=(4, 2), contact=(4, 2))
    assert odd[1].xticklabels == ("1:9", "2:8", "3:7", "4:6", "5:5", "6:4", "7:3", "8:2", "9:1")
    odd = parallelepiped_studies(elements=(8, 4, 2), split=(1, 1), interface=(4, 2))
    assert odd[1].xticklabels == ("5:5",)


def test_pin_joint_and_scene_studies():
    steps, holes = pin_joint_studies()
    assert holes.x == tuple(range(2, 11)) and holes.xscale == "linear"
    for n in (2, 10):
        ref = compare(pin_joint_sizes(n))
        for alg in ALGORITHMS:
            got = holes.percent_of_full[alg][n - 2]
            assert got == pytest.approx(ref[alg].percent_of_full, rel=1e-12)
    assert steps.percent_of_full["v-w-u"][-1] == pytest.approx(holes.percent_of_full["v-w-u"][-1])
    s_steps, s_changes = scene_studies(three_scene(), "three")
    assert (s_steps.name, s_changes.name) == ("three_steps", "three_changes")
    # gamma / N_TS = 1.5 is kept; each alpha scaled like gamma and rounded up
    i = STEPS_SWEEP.index(10)
    ref = flops_studies._rescaled(three_scene(), 10, 15)
    assert [c.alpha for c in ref.contacts] == [10, 5]
    assert s_steps.gflops_total["v-w-u"][i] == pytest.approx(
        operation_counts(ref, "v-w-u").gflops_total, rel=1e-12
    )


def test_plot_and_write_studies(tmp_path):
    study = parallelepiped_studies()[0]
    measured = {"v-w-u": [[10, 30.0], [1000, 1.2]], "FULL": [[10, 100.0]]}
    png = plot_study(study, tmp_path / "one.png", measured)
    assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 10_000
    file = tmp_path / "measured.json"
    file.write_text(json.dumps({"bar_steps": measured}))
    written = write_studies(parallelepiped_studies()[:2], tmp_path / "out", file)
    names = sorted(p.name for p in written)
    assert names == [
        "flops_bar_split.json",
        "flops_bar_split.png",
        "flops_bar_steps.json",
        "flops_bar_steps.png",
    ]
    data = json.loads((tmp_path / "out" / "flops_bar_steps.json").read_text())
    assert data["measured"] == measured
    assert data["percent_of_full"]["w-u"] == pytest.approx(list(study.percent_of_full["w-u"]))
    assert "measured" not in json.loads((tmp_path / "out" / "flops_bar_split.json").read_text())
