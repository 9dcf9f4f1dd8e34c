"""Blocks and contact regions: the typed names the assembly, schedule and solvers share."""

from __future__ import annotations

import pickle

from mpi4py import MPI

import numpy as np
import pytest
import scipy.sparse as sp

import dd_contact as dd
from dd_contact.blocks import Block, BlockSystem, ContactRegion, split_by_blocks
from dd_contact.paper import verify


def test_a_block_is_its_key():
    block = Block("u", "left")
    assert (block.kind, block.name) == ("u", "left")
    assert block == "u:left" and {block: 1}["u:left"] == 1 and {"u:left": 2}[block] == 2
    assert Block.parse("w:pad:1") == Block("w", "pad:1")  # only the first colon separates
    assert Block.parse(block) is block
    copy = pickle.loads(pickle.dumps(block))  # how blocks travel between ranks
    assert type(copy) is Block and (copy.kind, copy.name) == ("u", "left")


@pytest.mark.parametrize("key", ["left", "x:left"])
def test_a_malformed_block_name_is_refused(key):
    with pytest.raises(ValueError, match="block"):
        Block.parse(key)


def test_a_contact_region_shifts_into_a_larger_matrix():
    region = ContactRegion("pad", Block("w", "pad"), np.arange(3), sp.eye_array(3).tocsr())
    moved = region.shifted(10)
    assert moved.dofs.tolist() == [10, 11, 12] and region.dofs.tolist() == [0, 1, 2]
    assert moved.block is region.block and moved.pattern is region.pattern


def test_a_pair_split_again_gives_its_last_pieces_until_the_matrix_changes():
    a, b = Block("w", "a"), Block("w", "b")
    sizes = {a: 4, b: 5}
    region = ContactRegion("pair", a, np.array([0, 2]), sp.csr_array((3, 3)), b, np.array([4]))
    rng = np.random.default_rng(3)
    matrix = sp.csr_array(rng.integers(-3, 4, (3, 3)) * 1.0)
    first = region.in_blocks(matrix, sizes)
    assert len(first) == 4
    again = region.in_blocks(sp.csr_array(matrix, copy=True), sizes)  # equal, not the same
    assert again is not first and all(again[k] is first[k] for k in first)
    changed = matrix.copy()
    changed.data[0] += 1.0
    fresh = region.in_blocks(changed, sizes)
    for pair, piece in fresh.items():
        expected = split_by_blocks(region.parts, changed, sizes)[pair]
        assert piece is not first[pair]
        np.testing.assert_array_equal(piece.toarray(), expected.toarray())
    copied = pickle.loads(pickle.dumps(region))  # sent without its last split
    assert copied.in_blocks(changed, sizes)[(a, b)] is not fresh[(a, b)]


@pytest.mark.parametrize(
    ("kind", "kinds"),
    [
        ("interface", {"u": 2, "v": 1, "w": 1}),
        ("boundary", {"u": 2, "v": 1}),
        ("single", {"u": 1, "w": 1}),
    ],
)
def test_assembly_names_every_block_from_the_scene(kind, kinds):
    scene = verify.order_scene(kind, False, 1e4, MPI.COMM_SELF)
    problem = dd.StaticProblem(scene, algorithm="FULL")
    sizes = problem.solver.system.sizes
    assert all(type(b) is Block for b in sizes)
    counted = {k: sum(b.kind == k for b in sizes) for k in "uvw"}
    assert {k: n for k, n in counted.items() if n} == kinds
    assert {sub.block for sub in scene.subdomains} == {b for b in sizes if b.kind == "u"}
    for zone, contact in zip(problem.zones, scene.contacts, strict=True):
        region = zone.region
        assert region.name == contact.name and region.block == contact.block
        assert region.block.kind == ("u" if kind == "boundary" else "w")
        assert region.pattern.shape == (len(region.dofs), len(region.dofs))
    problem.close()


# -- the block algebra of BlockSystem, against the dense symmetric matrix ------------------
# Integer entries and vectors: every sum is exact, so any order of summation gives the dense
# product's value to the last bit.
_U, _V, _W, _LONE = Block("u", "a"), Block("v", "b"), Block("w", "c"), Block("u", "lone")
_SIZES = {_U: 5, _V: 3, _W: 4, _LONE: 2}


def _integer_matrix(rng, shape, symmetric=False) -> sp.csr_array:
    A = rng.integers(-4, 5, shape) * (rng.random(shape) < 0.5)
    return sp.csr_array(A + A.T if symmetric else A, dtype=float)


def _system_and_dense():
    """A system storing (u, v) and (w, u) and (w, v) once, and the full matrix they stand for."""
    rng = np.random.default_rng(7)
    system = BlockSystem(dict(_SIZES), dict.fromkeys(_SIZES, 0))
    for block, n in _SIZES.items():
        system.add(block, block, _integer_matrix(rng, (n, n), symmetric=True))
    for row, col in ((_U, _V), (_W, _U), (_W, _V)):
        system.add(row, col, _integer_matrix(rng, (_SIZES[row], _SIZES[col])))
    offsets = dict(zip(_SIZES, np.cumsum([0, *_SIZES.values()])[:-1].tolist(), strict=True))
    where = {b: slice(offsets[b], offsets[b] + n) for b, n in _SIZES.items()}
    dense = np.zeros((sum(_SIZES.values()),) * 2)
    for (row, col), A in system.matrices.items():
        dense[where[row], where[col]] = A.toarray()
        dense[where[col], where[row]] = A.toarray().T
    return system, dense, where, offsets


def test_a_block_is_the_stored_matrix_or_its_transpose():
    system, dense, where, _ = _system_and_dense()
    for row in _SIZES:
        for col in _SIZES:
            expected = dense[where[row], where[col]]
            block = system.block(row, col)
            if not expected.any():
                assert block is None, (row, col)
                continue
            np.testing.assert_array_equal(block.toarray(), expected)
    # a transpose is a view of the stored matrix, no copy
    assert np.shares_memory(system.block(_V, _U).data, system.matrices[(_U, _V)].data)
    assert system.block(_U, _V) is system.matrices[(_U, _V)]


def test_a_transpose_is_made_once_and_follows_its_stored_block():
    system, dense, where, _ = _system_and_dense()
    first = system.block(_V, _U)
    assert system.block(_V, _U) is first  # kept: block rows are read many times a step
    assert [A for c, A in system.block_row(_V) if c == _U] == [first]
    system.matrices[(_U, _V)].data *= 2.0  # changed in place: the view sees it
    np.testing.assert_array_equal(first.toarray(), 2.0 * dense[where[_V], where[_U]])
    system.matrices[(_U, _V)] = sp.csr_array(-dense[where[_U], where[_V]])  # replaced
    again = system.block(_V, _U)
    assert again is not first
    np.testing.assert_array_equal(again.toarray(), -dense[where[_V], where[_U]])
    copied = pickle.loads(pickle.dumps(system))  # sent without the cache
    np.testing.assert_array_equal(copied.block(_V, _U).toarray(), again.toarray())


def test_all_blocks_gives_each_block_of_the_symmetric_matrix_once_stored_first():
    system, dense, where, _ = _system_and_dense()
    blocks = list(system.all_blocks())
    pairs = [(row, col) for row, col, _ in blocks]
    assert len(set(pairs)) == len(pairs)
    nonzero = {(r, c) for r in _SIZES for c in _SIZES if dense[where[r], where[c]].any()}
    assert set(pairs) == nonzero
    for row, col, A in blocks:
        np.testing.assert_array_equal(A.toarray(), dense[where[row], where[col]])
    expected = []
    for row, col in system.matrices:
        expected += [(row, col)] + ([(col, row)] if row != col else [])
    assert pairs == expected


def test_a_block_row_and_the_coupled_blocks():
    system, dense, where, _ = _system_and_dense()
    for row in _SIZES:
        in_row = list(system.block_row(row))
        cols = [col for col, _ in in_row]
        assert set(cols) == {c for c in _SIZES if dense[where[row], where[c]].any()}
        assert cols == [c for r, c, _ in system.all_blocks() if r == row]  # their order
        for col, A in in_row:
            np.testing.assert_array_equal(A.toarray(), dense[where[row], where[col]])
        coupled = list(system.coupled(row))
        assert [c for c, _ in coupled] == [c for c in cols if c != row]
        for (c1, A1), (c2, A2) in zip(coupled, [p for p in in_row if p[0] != row], strict=True):
            assert c1 == c2
            np.testing.assert_array_equal(A1.toarray(), A2.toarray())
    assert [c for c, _ in system.coupled(_LONE)] == []


def test_a_row_product_is_the_dense_product():
    system, dense, where, _ = _system_and_dense()
    rng = np.random.default_rng(8)
    x = {b: rng.integers(-9, 10, n).astype(float) for b, n in _SIZES.items()}
    full = np.concatenate([x[b] for b in _SIZES])
    for row in _SIZES:
        product = system.row_product(row, x)
        np.testing.assert_array_equal(product, dense[where[row]] @ full)
        # a block missing from x counts as zero
        partial = {b: v for b, v in x.items() if b != _V}
        without = np.concatenate([partial.get(b, np.zeros(n)) for b, n in _SIZES.items()])
        np.testing.assert_array_equal(system.row_product(row, partial), dense[where[row]] @ without)
        assert system.row_product(row, x) is not product  # a new array each time
        np.testing.assert_array_equal(system.row_product(row, x), product)


def test_triplets_and_prescribed_columns_are_the_dense_matrix():
    system, dense, where, offsets = _system_and_dense()
    rows, cols, values = system.triplets(offsets)
    assembled = sp.coo_array((values, (rows, cols)), shape=dense.shape).toarray()
    np.testing.assert_array_equal(assembled, dense)
    dofs = np.array([0, 1])  # every block has these
    for block in _SIZES:
        columns = system.prescribed_columns(block, dofs)
        assert [r for r, _ in columns] == [r for r, _ in system.block_row(block)]
        for row, A in columns:
            np.testing.assert_array_equal(A.toarray(), dense[where[row], where[block]][:, dofs])
