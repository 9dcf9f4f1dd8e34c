"""Half-bandwidths for the operation-count model: structured hexahedral boxes and sparse matrices.

Closed forms for structured box meshes of 8-node hexahedra (:func:`half_bandwidth_structured_hex`,
:func:`half_bandwidth_box`) and the half-bandwidth of an assembled matrix in its own numbering or
after a reverse Cuthill-McKee reordering (:func:`matrix_half_bandwidth`,
:func:`rcm_half_bandwidth`; scipy is imported only there).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dd_contact.paper.flops.model import check_positive

__all__ = [
    "half_bandwidth_box",
    "half_bandwidth_structured_hex",
    "matrix_half_bandwidth",
    "rcm_half_bandwidth",
]


def half_bandwidth_structured_hex(nx: int, ny: int, nz: int, dofs_per_node: int = 3) -> int:
    """Half-bandwidth (diagonal included) of a structured box mesh of 8-node hexahedra.

    Nodes ``(i, j, k)``, ``0 <= i <= nx`` etc., are numbered ``n = (i (ny + 1) + j)(nz + 1) + k``
    (x slowest, z fastest) and dofs interleaved, ``dof = dofs_per_node * n + c``. Two nodes share
    an element iff their indices differ by at most 1 in each direction, so the largest node
    offset is ``(ny + 1)(nz + 1) + (nz + 1) + 1``. The largest dof offset adds
    ``dofs_per_node - 1`` (component 0 of the lower to the last component of the upper node),
    and the diagonal adds 1::

        B = dofs_per_node * ((ny + 1)(nz + 1) + (nz + 1) + 1) + dofs_per_node
          = dofs_per_node * ((ny + 2)(nz + 1) + 2)

    e.g. 400 x 100 x 10: ``3 * (102 * 11 + 2) = 3372``. ``nx`` does not enter (for ``nx >= 1``).

    Args:
        nx: Elements along x (numbered slowest; put the long direction here).
        ny: Elements along y.
        nz: Elements along z (numbered fastest).
        dofs_per_node: Unknowns per node.

    Returns:
        The half-bandwidth ``B``.
    """
    for name, v in (("nx", nx), ("ny", ny), ("nz", nz), ("dofs_per_node", dofs_per_node)):
        check_positive(name, v)
    max_node_offset = (ny + 1) * (nz + 1) + (nz + 1) + 1
    return dofs_per_node * max_node_offset + dofs_per_node


def half_bandwidth_box(nx: int, ny: int, nz: int, dofs_per_node: int = 3) -> int:
    """Smallest structured half-bandwidth of an ``nx x ny x nz`` box of hexahedra.

    Of the six axis orders of :func:`half_bandwidth_structured_hex` the best numbers the longest
    direction slowest and the shortest fastest: ``B = dofs_per_node ((n_mid + 2)(n_short + 1) +
    2)``. (With ``(m + 2)(s + 1) - (s + 2)(m + 1) = s - m``, the larger of the two remaining
    directions belongs in the middle.)

    Args:
        nx: Elements along x.
        ny: Elements along y.
        nz: Elements along z.
        dofs_per_node: Unknowns per node.

    Returns:
        The half-bandwidth ``B``.
    """
    n_long, n_mid, n_short = sorted((nx, ny, nz), reverse=True)
    return half_bandwidth_structured_hex(n_long, n_mid, n_short, dofs_per_node)


def _pattern(matrix: Any) -> tuple[np.ndarray, np.ndarray, int]:
    from scipy.sparse import coo_array

    coo = coo_array(matrix)
    if coo.shape[0] != coo.shape[1]:
        raise ValueError(f"matrix must be square, got shape {coo.shape}")
    return np.asarray(coo.row), np.asarray(coo.col), int(coo.shape[0])


def matrix_half_bandwidth(matrix: Any) -> int:
    """Half-bandwidth (diagonal included) of a sparse matrix in its present numbering.

    Args:
        matrix: A square scipy sparse matrix or array (e.g. the ``to_scipy()`` of an assembled
            dolfinx matrix) or a dense array; only the pattern of stored entries is used.

    Returns:
        ``max |i - j| + 1`` over the stored entries (1 for an empty matrix).
    """
    row, col, _ = _pattern(matrix)
    return int(np.abs(row - col).max()) + 1 if row.size else 1


def rcm_half_bandwidth(matrix: Any) -> int:
    """Half-bandwidth after a reverse Cuthill-McKee reordering (scipy's, symmetric pattern).

    Args:
        matrix: As for :func:`matrix_half_bandwidth`.

    Returns:
        The half-bandwidth in the reverse Cuthill-McKee numbering.
    """
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    row, col, n = _pattern(matrix)
    if not row.size:
        return 1
    sym = coo_array(
        (np.ones(2 * row.size, dtype=np.int8), (np.r_[row, col], np.r_[col, row])), shape=(n, n)
    ).tocsr()
    perm = reverse_cuthill_mckee(sym, symmetric_mode=True)
    rank = np.empty(n, dtype=np.int64)
    rank[perm] = np.arange(n)
    return int(np.abs(rank[row] - rank[col]).max()) + 1
