# # The paper's parallelepiped: a steel bar shaken against a rigid wall
#
# The first example of Kim, Ryu and Shin (method.md 7.1; `docs/models.md`): a steel bar
# 400 x 100 x 10 mm of hexahedra, cut across its length into two independently meshed
# subdomains tied through an interface mesh, its end x = 0 facing a rigid wall on a contact
# interface of its own. The far end x = 0.4 m is clamped; a body force
# b sin(2 pi t / T) along -x (b = 21 MN/m^3, T = 4 ms) pushes the free end onto the wall
# for half a period and pulls it off for the other half. The wall is tilted by 2e-5 rad,
# so contact spreads across the end face row by row and the contact state changes many
# times per period.
#
# Every algorithm runs the same 80 steps of 0.1 ms (two periods) with Newmark's
# trapezoidal rule and **energy-safe contact** (`TransientProblem(energy_safe_contact=True)`,
# docs/contact.md "Impact": massless contact walls, and a point that leaves contact lets
# go over its step, so contact never creates energy). FULL, v-w-u and w-v-u run on the
# split model; w-u runs on the bar as one mesh (no interface) and v-u with contact on the
# subdomain's own boundary (no contact interface), each compared with FULL on its own model.
# The runs track the energy: with it the coarse-step monitor tells the bar's bearing contact
# (pressed on by the load, 17 steps of 0.1 ms, already within 1-3 % of dt / 10 in impulse,
# peak force and peak displacement; docs/contact.md) from an impact, which it is not.
#
# Run it with `python demos/demo_parallelepiped.py`; `--scale tiny` (tests), `small`
# (default), `paper` (400 x 100 x 10 hexahedra, 1.3 million dofs) or a fraction of the
# paper's resolution; `--algorithm NAME` runs one algorithm (and FULL to compare).

# +
import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from dd_contact import post, viz
from dd_contact.paper import compare, models

ALGORITHMS = ("FULL", "v-w-u", "w-v-u", "w-u", "v-u", "auto")
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--scale", default="small", help="tiny, small, paper or a fraction")
parser.add_argument("--algorithm", choices=ALGORITHMS, help="one algorithm (and FULL)")
parser.add_argument("--steps", type=int, default=80, help="time steps of 0.1 ms")
parser.add_argument("--out", default="demo_output/parallelepiped", help="output directory")
args = parser.parse_args()
try:
    scale = args.scale if args.scale in models.BAR_SCALES else float(args.scale)
except ValueError:
    parser.error(f"--scale {args.scale!r}: give tiny, small, paper or a fraction such as 0.25")
out = Path(args.out)
out.mkdir(parents=True, exist_ok=True)
comm = MPI.COMM_WORLD
start = time.perf_counter()
DT, PERIOD, B = 1e-4, 4e-3, 21e6  # time step [s], load period [s], body force [N/m^3]
LENGTH, WIDTH, HEIGHT = models.BAR_SIZE
VOLUME = LENGTH * WIDTH * HEIGHT
asked = [args.algorithm] if args.algorithm else list(ALGORITHMS)
algorithms = ["FULL", *[a for a in asked if a != "FULL"]]
# -

# ## The runs
#
# `models.parallelepiped(scale, algorithm=...)` builds the model variant an algorithm needs
# (`models.LAYOUTS`). `compare.run_algorithm` time-steps a fresh model with one algorithm
# and keeps its contact history, work, step times and displacements. On every model FULL
# also runs a second time with another MUMPS ordering (`compare.roundoff_run`): how far two
# exact solvers of the same equations drift apart by round-off, the yardstick of the
# comparison (docs/compare.md). The deformed bar is drawn from FULL's run at the peak push
# (t = 1 ms).

# +
MODEL_OF = {"w-u": "w-u", "v-u": "v-u"}  # the others run on the split model (None)
MODEL_NAME = {
    None: "split, contact intf.",
    "w-u": "one mesh, contact intf.",
    "v-u": "split, no contact intf.",
}


def bar(layout):
    return lambda: models.parallelepiped(scale, algorithm=layout, body_force=B, period=PERIOD)


def draw_peak_push(scene, problem):
    post.gather_contact_fields(scene)
    if comm.rank == 0:
        viz.plot_deformed(
            scene,
            out / "bar_deformed.png",
            title=f"Bar at the peak push (t = {problem.t * 1e3:.1f} ms), von Mises stress",
        )


runs, references, roundoff = [], {}, {}
for algorithm in algorithms:
    layout = MODEL_OF.get(algorithm)
    if layout not in roundoff:  # FULL on this algorithm's model, and its round-off twin
        if layout is not None:
            references[layout] = compare.run_algorithm(
                bar(layout), "FULL", DT, args.steps, MODEL_NAME[layout], track_energy=True
            )
        roundoff[layout] = compare.roundoff_run(
            bar(layout), DT, args.steps, MODEL_NAME[layout], track_energy=True
        )
    peak = round(PERIOD / 4 / DT) if algorithm == "FULL" else None
    runs.append(
        compare.run_algorithm(
            bar(layout),
            algorithm,
            DT,
            args.steps,
            MODEL_NAME[layout],
            peak,
            draw_peak_push,
            track_energy=True,
        )
    )
full = runs[0]
checks = {}
for r in runs[1:]:
    layout = MODEL_OF.get(r.algorithm)
    checks[r.algorithm] = compare.agreement(
        r, references.get(layout, full), ["end"], roundoff[layout]
    )
# -

# ## The quasi-static limit
#
# The same load in quasi-static steps (no inertia): the wall and the clamp then carry the
# body force between them, to round-off, at every step.

# +
quasi = compare.run_algorithm(bar(None), "w-v-u", DT, args.steps, "quasi-static", inertia=False)
times = np.array([r["t"] for r in quasi.history])
applied = B * VOLUME * np.sin(2 * np.pi * times / PERIOD)  # pushes towards the wall (-x)
wall = np.array([r["force"]["end"][0] for r in quasi.history])
clamp = np.array([r["reaction"]["Omega2"][0] for r in quasi.history])
balance = np.abs(wall + clamp - applied).max() / np.abs(applied).max()
# -

# ## The table
#
# Contact state changes, factorisations and substitutions (right-hand sides) summed over
# the blocks, the wall time of the steps, the paper's operation-count model for this scene
# and these changes (`dd_contact.paper.flops`), and how each run compares with FULL on the same
# model: the largest displacement difference, relative to the largest displacement of the
# run, after each of the first 2 steps (below 1e-8), the largest at steps 1, 2, 4, 8, ...
# and the last ("worst"), the limit it must stay within (10x the round-off twin's, at least
# 1e-6), and whether the contact history (active points in every step) is the same.

# +
scene = bar(None)()
everything = [*runs, *references.values(), *roundoff.values()]
gflops = compare.model_gflops(scene, args.steps, full.changes)
text = compare.table(everything, checks, gflops)
dofs = sum(s.num_dofs for s in scene.subdomains)
if comm.rank == 0:
    plt = compare.pyplot()
    names = ["end"]
    points = {"end": scene.contacts[0].num_dofs // 3}
    compare.strip_chart(
        out / "bar_contact_strip.png", np.array([r["t"] for r in full.history]),
        full.active(names), points, names, "Bar end on the wall: points in contact (FULL)",
    )  # fmt: skip
    fig, ax = plt.subplots(figsize=(8, 4))
    t_ms = 1e3 * times
    ax.plot(t_ms, 1e-3 * applied, "k--", label="applied body force (towards the wall)")
    ax.plot(
        t_ms,
        1e-3 * np.array([r["force"]["end"][0] for r in full.history]),
        label="wall force, dynamic (FULL)",
    )
    ax.plot(t_ms, 1e-3 * wall, label="wall force, quasi-static")
    ax.plot(t_ms, 1e-3 * clamp, ":", label="clamp reaction, quasi-static")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("force along x [kN]")
    ax.set_title("Contact force on the bar's end against the applied load")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "bar_forces.png", dpi=110)
    plt.close(fig)
    compare.step_time_chart(out / "bar_step_times.png", everything, "Bar: wall time of each step")
    summary = compare.summary(
        everything, checks, gflops,
        scale=str(args.scale), dofs=dofs, steps=args.steps, balance=balance, table=text,
    )  # fmt: skip
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(
        f"parallelepiped, scale {args.scale} ({dofs} dofs): {args.steps} steps of {DT * 1e3:g} ms"
    )
    print(f"quasi-static balance |wall + clamp - load| / load = {balance:.1e}")
    print(
        f"pictures in {out}/: bar_deformed.png, bar_contact_strip.png, bar_forces.png, "
        "bar_step_times.png"
    )
    print(f"wall time {time.perf_counter() - start:.1f} s")
    print(text)
problem = compare.disagreements(checks)
if problem:
    raise SystemExit(problem)
# -
