"""How accurate is a corrected contact change? Every solver against an extended-precision reference.

``benchmarks/lowrank_change.py`` compares the corrected solution of a flipped contact state
with the re-factorised one. On the 87k joint they differ by a few 1e-6 of the largest w:
is that the correction losing digits, or both solves' forward error (penalty 1e6)? Here,
on the same flipped state of the joint with elastic pins (settled statically at the load's
peak, then a fraction of its contact points flipped with ``lowrank_change.py`` 's random
draw), one process solves it with:

* ``corrected``: w-v-u with the Woodbury correction (refined, as the solver runs);
* ``corrected_unrefined``: the same correction without its refinement (what the refinement
  gives back, and whether the correction's own check sees it: its backward error on the
  condensed surface system against ``lowrank.UPDATE_TOLERANCE``);
* ``refactorised``: w-v-u re-factorising the all-walls group; ``v-w-u``: re-factorising its
  groups; ``FULL``: MUMPS on the whole system (14).

The whole system ``K x = b`` (contact terms included) is assembled once as a sparse matrix;
the reference is MUMPS's solution refined with residuals in extended precision (numpy's
longdouble) until they stop falling. For each solver: its normwise backward error on the
whole system ``|b - K x|_inf / (|K|_inf |x|_inf + |b|_inf)``, its difference from the
reference (relative to the reference's largest entry; on the contact interfaces' w as
``lowrank_change.py`` compares, and on every dof), and the surface backward error the
correction's own check computes (Frobenius, on the condensed surface system). The 1-norm
condition number of K (Hager-Higham estimate) bounds the forward error of a backward-stable
solve: about cond times 1e-16.

    python benchmarks/lowrank_accuracy.py --scale 3,2,1,4    # 5,460 dofs
    python benchmarks/lowrank_accuracy.py                    # 6,7,4,34: 87,405 dofs

Writes benchmarks/results/lowrank_accuracy[_<scale>].json.
"""

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

DEFAULT_SCALE = "6,7,4,34"
PERIOD = 2e-3
REFERENCE_REFINEMENTS = 8


def _scene(scale: str):
    from mpi4py import MPI

    from dd_contact.paper import models

    names = list(models.PIN_JOINT_SCALES["small"])
    counts = dict(zip(names, map(int, scale.split(",")), strict=True))
    layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
    return models.pin_joint(layout, clearance=0.0, pins="elastic", comm=MPI.COMM_SELF)


def _flipped(settled: dict, fraction: float) -> dict:
    """``lowrank_change.py`` 's first draw at ``fraction`` (its first trial at 1 %)."""
    points = sum(len(a) for a in settled.values())
    rng = np.random.default_rng(28)
    flips = rng.choice(points, size=max(1, int(fraction * points)), replace=False)
    flat = np.concatenate(list(settled.values())).copy()
    flat[flips] = ~flat[flips]
    out, start = {}, 0
    for k, a in settled.items():
        out[k] = flat[start : start + len(a)]
        start += len(a)
    return out


class SurfaceSpy:
    """The backward error of every surface solve, as the correction's check computes it."""

    def __init__(self, surface):
        from dd_contact.solvers import lowrank

        self.surface, self.errors, self.relative = surface, [], []
        self._solve, self._norm = surface.solve, lowrank.norm_of
        surface.solve = self.solve

    def solve(self, g, complete):
        x = self._solve(g, complete)
        s = self.surface
        whole = x if set(x) == set(g) else s.back_substitute(x)
        r = s._residual(g, whole)
        norm = self._norm
        self.errors.append(norm(r) / (s._matrix_norm() * norm(whole) + norm(g)))
        self.relative.append(norm(r) / norm(g))
        return x


class Whole:
    """The whole system (14) with the flipped contact terms, one sparse matrix."""

    def __init__(self, system, rhs: dict, contact: list):
        names = sorted(str(b) for b in system.sizes)
        sizes = {str(b): n for b, n in system.sizes.items()}
        self.offsets = dict(zip(names, np.cumsum([0] + [sizes[n] for n in names]), strict=False))
        self.sizes, self.names = sizes, names
        n = int(sum(sizes.values()))
        rows, cols, values = system.triplets(self.offsets)
        K = sp.coo_array((values, (rows, cols)), shape=(n, n)).tocsr()
        for parts, matrix in contact:
            index = np.concatenate([self.offsets[str(b)] + dofs for b, dofs in parts])
            m = sp.coo_array(matrix)
            K = K + sp.csr_array((m.data, (index[m.row], index[m.col])), shape=(n, n))
        self.K = K.tocsr()
        self.K.sum_duplicates()
        self.b = self.vector(rhs)
        self.K_ext = self.K.astype(np.longdouble)
        self.norm = float(abs(self.K).sum(axis=1).max())  # |K|_inf

    def vector(self, blocks: dict) -> np.ndarray:
        out = np.zeros(sum(self.sizes.values()))
        for name, v in blocks.items():
            out[self.offsets[str(name)] : self.offsets[str(name)] + len(v)] += v
        return out

    def w(self, x: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [
                x[self.offsets[k] : self.offsets[k] + self.sizes[k]]
                for k in self.names
                if k[0] == "w"
            ]
        )

    def backward_error(self, x) -> float:
        r = self.b.astype(np.longdouble) - self.K_ext @ np.asarray(x, np.longdouble)
        scale = self.norm * np.abs(x).max() + np.abs(self.b).max()
        return float(np.abs(r).max() / scale)


def _mumps(K: sp.csr_array):
    from petsc4py import PETSc

    csr = (K.indptr.astype(PETSc.IntType), K.indices.astype(PETSc.IntType), K.data)
    A = PETSc.Mat().createAIJ(K.shape, csr=csr, comm=PETSc.COMM_SELF)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setOperators(A)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    ksp.setUp()
    b, x = A.createVecs()

    def solve(v: np.ndarray) -> np.ndarray:
        b.setArray(np.asarray(v, np.float64))
        ksp.solve(b, x)
        return x.getArray().copy()

    return solve


def reference(whole: Whole) -> dict:
    """MUMPS refined with extended-precision residuals; K's condition number (1-norm)."""
    solve = _mumps(whole.K)
    b = whole.b.astype(np.longdouble)
    x = np.zeros_like(b)
    history, steps = [], []
    for _ in range(REFERENCE_REFINEMENTS):
        r = b - whole.K_ext @ x
        history.append(float(np.abs(r).max() / np.abs(b).max()))
        if len(history) > 1 and history[-1] >= 0.5 * history[-2]:
            break
        dx = solve(r.astype(np.float64)).astype(np.longdouble)
        x = x + dx
        steps.append(float(np.abs(dx).max() / np.abs(x).max()))
    n = whole.K.shape[0]
    inverse = spla.LinearOperator((n, n), matvec=solve, rmatvec=solve, dtype=np.float64)
    cond = float(spla.onenormest(inverse) * abs(whole.K).sum(axis=0).max())
    # scaled to a unit diagonal (what Cholesky's error depends on: van der Sluis), without
    # the constrained rows' unit diagonal against the penalties' 1e15
    d = 1.0 / np.sqrt(whole.K.diagonal())

    def scaled_solve(v: np.ndarray) -> np.ndarray:
        return solve(v / d) / d

    scaled = spla.LinearOperator(
        (n, n), matvec=scaled_solve, rmatvec=scaled_solve, dtype=np.float64
    )
    DKD = abs(whole.K * d[:, None] * d[None, :])
    scaled_cond = float(spla.onenormest(scaled) * DKD.sum(axis=0).max())
    return {
        "x": x,
        "residual_history": history,
        "steps": steps,  # each refinement's change, relative to the largest entry
        "condition_1": cond,
        "scaled_condition_1": scaled_cond,
    }


def _solve(problem, active: dict, rhs: dict) -> dict:
    it = problem.iteration
    it.active = {k: a.copy() for k, a in active.items()}
    solver = problem.analysis.tie_solver
    it._solve_once(solver, rhs, "accuracy")
    return {k: v.copy() for k, v in solver.finish().items()}  # every block


def _counts(problem, first: int) -> dict:
    records = problem.work.records[first:]
    kinds = ("dense_update", "dense_factor", "sparse_factor")
    return {kind: sum(r.kind == kind for r in records) for kind in kinds}


def orders(scene, fraction: float) -> tuple[dict, tuple]:
    """Every solver's solution of the flipped state, its work and the correction's check."""
    import dd_contact as dc
    from dd_contact.solvers import lowrank
    from dd_contact.solvers.lowrank import LowRankSurface

    out = {}
    LowRankSurface.enabled = False  # settled by re-factorising, as lowrank_change.py
    with dc.StaticProblem(scene, algorithm="w-v-u") as problem:
        problem.solve(PERIOD / 4)
        it = problem.iteration
        settled = {k: a.copy() for k, a in it.active.items()}
        rhs = {k: v.copy() for k, v in it.last_solve[0].items()}
        flipped = _flipped(settled, fraction)
        surface = problem.analysis.solver.surface
        spy = SurfaceSpy(surface)
        surface.lowrank = True
        for label, refinements, tolerance in (
            ("corrected", lowrank.REFINEMENTS, lowrank.UPDATE_TOLERANCE),
            ("corrected_unrefined", 0, np.inf),
        ):
            saved = lowrank.REFINEMENTS, lowrank.UPDATE_TOLERANCE
            lowrank.REFINEMENTS, lowrank.UPDATE_TOLERANCE = refinements, tolerance
            first, spied = len(problem.work.records), len(spy.errors)
            x = _solve(problem, flipped, rhs)
            c = surface.correction
            out[label] = {
                "x": x,
                "work": _counts(problem, first),
                "surface_backward_error": spy.errors[spied:],
                "surface_relative_residual": spy.relative[spied:],
                "applications": surface.applications[-1] if surface.applications else None,
                "rank": c.rank,
                "capacitance_rcond": c.conditioned,
                "system": it.solved_system(problem.analysis.tie_solver),
            }
            lowrank.REFINEMENTS, lowrank.UPDATE_TOLERANCE = saved
            _solve(problem, settled, rhs)  # back: the correction emptied
        surface.lowrank = False
        first, spied = len(problem.work.records), len(spy.errors)
        x = _solve(problem, flipped, rhs)
        out["refactorised"] = {
            "x": x,
            "work": _counts(problem, first),
            "surface_backward_error": spy.errors[spied:],
            "surface_relative_residual": spy.relative[spied:],
        }
        system = problem.analysis._system
        solved = it.solved_system(problem.analysis.tie_solver)
    for algorithm in ("v-w-u", "FULL"):
        with dc.StaticProblem(scene, algorithm=algorithm) as problem:
            problem.iteration.start(PERIOD / 4)
            first = len(problem.work.records)
            x = _solve(problem, flipped, rhs)
            out[algorithm] = {"x": x, "work": _counts(problem, first)}
    info = {"points": sum(len(a) for a in settled.values())}
    info["points_changed"] = int(sum((flipped[k] != settled[k]).sum() for k in settled))
    return out, (system, solved, info)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scale", default=DEFAULT_SCALE, help="c,r,t,grip cell counts")
    parser.add_argument("--fraction", type=float, default=0.01, help="of the points flipped")
    parser.add_argument("--dump", help="an .npz of K, b and the solutions (for study)")
    parser.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = parser.parse_args()
    start = time.perf_counter()
    scene = _scene(args.scale)
    solutions, (system, (rhs, contact), info) = orders(scene, args.fraction)
    whole = Whole(system, rhs, contact)
    ref = reference(whole)
    x_ref = ref.pop("x")
    ref_w, ref_all = whole.w(x_ref.astype(np.float64)), x_ref.astype(np.float64)
    report = {
        "scale": args.scale,
        "fraction": args.fraction,
        "dofs": int(whole.K.shape[0]),
        **info,
        "reference": {
            **ref,
            "backward_error": whole.backward_error(x_ref),
            "refinements": len(ref["residual_history"]) - 1,
        },
        "solvers": {},
    }
    xs = {label: whole.vector(s.pop("x")) for label, s in solutions.items()}
    for label, s in solutions.items():
        if "system" in s:  # the same system every solver solved
            other = Whole(system, *s.pop("system"))
            assert np.array_equal(other.b, whole.b) and (other.K != whole.K).nnz == 0
        x = xs[label]
        row = {
            "backward_error": whole.backward_error(x),
            "relative_residual": float(
                np.linalg.norm(whole.b - whole.K @ x) / np.linalg.norm(whole.b)
            ),
            "difference_w": float(np.abs(whole.w(x) - ref_w).max() / np.abs(ref_w).max()),
            "difference_all": float(np.abs(x - ref_all).max() / np.abs(ref_all).max()),
            "difference_w_refactorised": float(
                np.abs(whole.w(x) - whole.w(xs["refactorised"])).max() / np.abs(ref_w).max()
            ),
            **s,
        }
        report["solvers"][label] = row
    if args.dump:
        np.savez(
            args.dump,
            data=whole.K.data,
            indices=whole.K.indices,
            indptr=whole.K.indptr,
            b=whole.b,
            reference=x_ref.astype(np.float64),
            names=np.array(whole.names),
            offsets=np.array([whole.offsets[k] for k in whole.names]),
            **{k: v for k, v in xs.items()},
        )
    report["seconds"] = time.perf_counter() - start
    suffix = "" if args.scale == DEFAULT_SCALE else f"_{args.scale}"
    suffix += "" if args.fraction == 0.01 else f"_{args.fraction:g}"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"lowrank_accuracy{suffix}.json").write_text(json.dumps(report, indent=1))
    print(
        f"{report['dofs']:,} dofs, cond_1(K) ~ {ref['condition_1']:.1e}, scaled "
        f"{ref['scaled_condition_1']:.1e}"
    )
    for label, row in report["solvers"].items():
        print(
            f"  {label:20s} backward {row['backward_error']:.1e}  |w - w_ref| "
            f"{row['difference_w']:.1e}  |x - x_ref| {row['difference_all']:.1e}  |w - w_refact| "
            f"{row['difference_w_refactorised']:.1e}"
        )


if __name__ == "__main__":
    main()
