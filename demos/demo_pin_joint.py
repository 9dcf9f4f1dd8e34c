# # The paper's multi-pin joint: two steel plates on five pins under a periodic load
#
# The second example of Kim, Ryu and Shin (method.md 7.2; `docs/models.md`): two steel
# plates 10 mm thick and 300 mm wide lapped over each other and joined by a row of five
# rigid pins of 20 mm diameter at a 60 mm pitch. Each plate is six subdomains (a hexahedral
# O-grid block around each hole and a grip), tied through one interface mesh; each of the
# ten hole walls is a contact interface of its own against its pin, 0.05 mm thinner than
# the hole. The joint is in tension and compression: the upper plate's grip end is pulled
# and pushed along y by 20 kN sin(2 pi t / T), T = 2 ms, the lower plate's by the same load
# the opposite way (both ends guided in x and z); the pins pass the load from one plate to
# the other. Both plates cross the clearance and rattle between the two sides of the pins:
# the contact state of all ten hole walls changes many times per period, on small contact
# interfaces of a large model, the case the method is made for.
#
# Every algorithm that fits the scene (FULL, v-w-u, w-v-u, and `auto`, which picks one)
# runs the same 1,250 steps of 1.6 us (one period) with Newmark's trapezoidal rule and
# **energy-safe contact** (`TransientProblem(energy_safe_contact=True)`, docs/contact.md
# "Impact": a point that leaves contact never creates energy).
#
# Run it with `python demos/demo_pin_joint.py`; `--scale 8,3,2,12` (default: the cell counts
# `c,r,t,grip`, 8 cells per quarter hole, `small` with twice its cells around the holes),
# `small`, `paper` (174,080 hexahedra) or other cell counts (`3,2,1,4` for the tests; the
# model's `"tiny"`, with 2 cells per quarter hole, is refused by the contact geometry check);
# `--algorithm NAME` runs one (and FULL). Why 8 cells per quarter hole: a hit on a pin is
# about 4 mm wide; `small`'s 4 cells (22.5 degrees, 3.9 mm) carry it on 2 nodes across, 5
# nodes' worth of wall, too few to resolve it (docs/contact.md, "A contact carried by too
# few points"); 8 cells carry it on 9-13.
# `--pins elastic` makes each pin a steel subdomain in contact pairs with its two hole
# walls instead (section "Elastic pins" below). `--friction 0.2` puts Coulomb friction on
# the hole walls against their rigid pins (section "Friction" below).

# +
import argparse
import dataclasses
import json
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import numpy as np

from dd_contact import post, viz
from dd_contact.paper import compare, models

ALGORITHMS = ("FULL", "v-w-u", "w-v-u", "auto")
parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument(
    "--scale",
    default="8,3,2,12",
    help="c,r,t,grip rows (cells, as docs/models.md), small or paper",
)
parser.add_argument("--algorithm", choices=ALGORITHMS, help="one algorithm (and FULL)")
parser.add_argument("--steps", type=int, default=1250, help="time steps of 1.6 us")
parser.add_argument("--out", default="demo_output/pin_joint", help="output directory")
parser.add_argument(
    "--pins", choices=("rigid", "elastic"), default="rigid", help="rigid (the paper's) or elastic"
)
parser.add_argument(
    "--friction", type=float, default=0.0, help="Coulomb's mu of the hole walls on the pins"
)
args = parser.parse_args()
if args.scale in models.PIN_JOINT_SCALES:
    layout = models.pin_joint_layout(args.scale)
else:  # c, r, t, grip rows
    names = list(models.PIN_JOINT_SCALES["small"])
    try:
        counts = dict(zip(names, map(int, args.scale.split(",")), strict=True))
    except ValueError:
        parser.error(f"--scale {args.scale!r}: give small, paper or four cell counts {names}")
    layout = dataclasses.replace(models.pin_joint_layout("small"), **counts)
out = Path(args.out)
out.mkdir(parents=True, exist_ok=True)
comm = MPI.COMM_WORLD
start = time.perf_counter()
# -

# ## Elastic pins (`--pins elastic`)
#
# Each pin a steel subdomain through both plates, held at its two ends, in a contact pair
# with each of its two hole walls (`models.pin_joint(pins="elastic")`; the hole wall is the
# pair's side a). Without clearance, pulled statically to the load's peak (t = T/4): the
# pins' von Mises stress, FULL against v-w-u, and the pins' forces and the joint's
# stretch as the pins' Young's modulus grows (x1, x10, x100 steel's) against the
# rigid-pin model (`elastic_pins.towards_rigid`).

# +
if args.pins == "elastic":
    from dd_contact import StaticProblem
    from dd_contact.paper.models.elastic_pins import towards_rigid

    solved = {}
    for algorithm in ("FULL", "v-w-u"):
        scene = models.pin_joint(layout, clearance=0.0, pins="elastic")
        with StaticProblem(scene, algorithm=algorithm) as problem:
            problem.solve(0.25 * 2e-3)
            solved[algorithm] = np.concatenate([s.u.x.array for s in scene.subdomains])
    gap = np.abs(solved["v-w-u"] - solved["FULL"]).max() / np.abs(solved["FULL"]).max()
    post.gather_contact_fields(scene)
    pins = [s.name for s in scene.subdomains if s.name.startswith("pin")]
    limit = towards_rigid(layout, comm=comm)
    if comm.rank == 0:
        title = "Elastic pins, joint pulled to 20 kN (t = T/4), von Mises stress"
        viz.plot_deformed(scene, out / "pins_von_mises.png", title=title, subdomains=pins)
        viz.plot_deformed(scene, out / "joint_elastic_pins.png", title=title)
        dofs = sum(s.num_dofs for s in scene.subdomains)
        print(f"pin joint with elastic pins, scale {args.scale} ({dofs} dofs)")
        print(f"v-w-u against FULL: max |u - u_FULL| / max |u_FULL| = {gap:.2e}")
        print("E_pin / E_steel | pin forces vs rigid (worst) | grip end displacement vs rigid")
        for row in limit["rows"]:
            print(
                f"{row['factor']:>15g} | {100 * row['force_difference']:>26.2f} % |"
                f" {100 * row['u_difference']:>+29.2f} %"
            )
        (out / "elastic_pins.json").write_text(json.dumps({"v-w-u_vs_FULL": gap, **limit}))
        print(f"pictures in {out}/: pins_von_mises.png, joint_elastic_pins.png")
    raise SystemExit(0)
# -

# +
# The plates rattle across the clearance: each hit on a pin is an impact of 0.12-0.2 ms,
# resolved in 60 steps or more at 1.6 us (docs/contact.md, "A time step too coarse for the
# impact": at 40 us the pin forces were 18 % off in impulse and 24 % in peak; at 2.5 us a
# hit of 0.14 ms took 57 steps, at 2 us one of 0.12 ms 58).
DT, PERIOD, LOAD = 1.6e-6, 2e-3, 20e3  # time step [s], load period [s], load amplitude [N]
PINS = 5
asked = [args.algorithm] if args.algorithm else list(ALGORITHMS)
algorithms = ["FULL", *[a for a in asked if a != "FULL"]]
walls = [f"hole_{plate}{k}" for plate in ("upper", "lower") for k in range(PINS)]


def joint(clearance=0.05e-3, friction=args.friction):
    return lambda: models.pin_joint(
        layout, clearance=clearance, load=LOAD, period=PERIOD, friction=friction
    )


# With friction every run tracks its energy: each step's dissipation and the balance.
ENERGY = {"track_energy": True} if args.friction else {}


# -

# ## The runs
#
# The deformed joint and the pressure on the hole walls are drawn from FULL's run at the
# first peak pull (t = 0.52 ms), when both plates bear on their pins. FULL runs a second
# time with another MUMPS ordering (`compare.roundoff_run`): the round-off yardstick of
# the comparison (docs/compare.md).


# +
def draw_peak_pull(scene, problem):
    post.gather_contact_fields(scene)
    if comm.rank == 0:
        when = f"t = {problem.t * 1e3:.2f} ms"
        viz.plot_deformed(
            scene, out / "joint_deformed.png", title=f"Pin joint pulled ({when}), von Mises stress"
        )
        rows = [[f"hole_{plate}{k}" for k in range(PINS)] for plate in ("upper", "lower")]
        viz.plot_wall_pressures(
            scene, out / "joint_pressure.png", rows,
            title=f"Contact pressure on the hole walls, unrolled around each pin ({when})",
        )  # fmt: skip
        viz.plot_contact_pressures(
            scene, out / "joint_pressure_3d.png", view=(0.0, -1.0, 0.25),
            title=f"Contact pressure on the hole walls from -y, upper plate on top ({when})",
        )  # fmt: skip


MODEL = "12 subd., 10 contact i."
runs = []
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    for algorithm in algorithms:
        peak = round(0.26 * PERIOD / DT) if algorithm == "FULL" else None
        runs.append(
            compare.run_algorithm(
                joint(), algorithm, DT, args.steps, MODEL, peak, draw_peak_pull, **ENERGY
            )
        )
    full = runs[0]
    roundoff = compare.roundoff_run(joint(), DT, args.steps, MODEL, **ENERGY)
for w in caught:  # shown as they would have been
    warnings.showwarning(w.message, w.category, w.filename, w.lineno)
checks = {r.algorithm: compare.agreement(r, full, walls, roundoff) for r in runs[1:]}
# -

# ## Friction (`--friction MU`)
#
# Each hole wall with Coulomb friction against its rigid pin (`models.pin_joint(friction=)`,
# docs/contact.md "Friction"). Every run's frictional dissipation is never negative, step by
# step, and its energy balance (energy now = energy before + loads' work - dissipation)
# holds within the energy check's tolerance (`monitors.EnergyBalance`): no
# `EnergyGrowthWarning`, no warning at all.

# +
friction_lines, friction_failures = [], []
if args.friction:
    for r in [*runs, roundoff]:
        dissipated = np.array([h["energy"]["dissipated"] for h in r.history])
        gains = np.array([g[1:] for g in r.gains]).reshape(-1, 2)
        worst = float((gains[:, 0] / gains[:, 1]).max(initial=0.0))
        friction_lines.append(
            f"friction mu = {args.friction:g}, {r.label}: dissipated {dissipated.sum():.4g} J over "
            f"the run, per step >= 0 (least {dissipated.min():.3g} J); energy balance: largest "
            f"gain {gains[:, 0].max(initial=0.0):.3g} J, {worst:.3g} of its tolerance"
        )
        if dissipated.min() < 0.0 or worst > 1.0:
            friction_failures.append(r.label)
    if caught:
        friction_failures.append(f"{len(caught)} warning(s)")
# -

# ## The quasi-static limit
#
# On touching pins (no clearance) in quasi-static steps the pins pass the load from one
# plate to the other: the total force each plate puts on the pins along its load equals the
# applied load at every step, to round-off.

# +
# (frictionless: with friction the touching pins' walls chatter between stick and slip at
# the Coulomb limit, and a load step does not settle: docs/demo_pin_joint.md, "Friction")
quasi = compare.run_algorithm(
    joint(0.0, 0.0), "w-v-u", DT, args.steps, "quasi-static", inertia=False
)
times = np.array([r["t"] for r in quasi.history])
applied = LOAD * np.sin(2 * np.pi * times / PERIOD)


PULLED = {"upper": 1.0, "lower": -1.0}  # each plate's load along y, per unit applied load


def pin_forces(history, plate):
    """Force each pin takes from one plate along that plate's load [N] (steps x pins)."""
    along = PULLED[plate]
    return np.array(
        [[-along * r["force"][f"hole_{plate}{k}"][1] for k in range(PINS)] for r in history]
    )


quasi_pins = {plate: pin_forces(quasi.history, plate) for plate in PULLED}
balance = max(np.abs(p.sum(axis=1) - applied).max() for p in quasi_pins.values()) / LOAD
# -

# ## The table and the charts
#
# As for the parallelepiped (`demos/demo_parallelepiped.py`): contact state changes,
# factorisations, substitutions, wall time, the operation-count model's GFLOPs for this
# scene and these changes, time relative to FULL, and the agreement with FULL (after each
# of the first 2 steps, the worst over the run against its limit, and the contact history).

# +
scene = joint()()
gflops = compare.model_gflops(scene, args.steps, full.changes)
text = compare.table([*runs, roundoff], checks, gflops)
dofs = sum(s.num_dofs for s in scene.subdomains)
if comm.rank == 0:
    plt = compare.pyplot()
    points = {c.name: c.num_dofs // 3 for c in scene.contacts}
    compare.strip_chart(
        out / "joint_contact_strip.png", np.array([r["t"] for r in full.history]),
        full.active(walls), points, walls, "Hole walls in contact with their pins (FULL)",
    )  # fmt: skip
    fig, axes = plt.subplots(1, 2, figsize=(12, 4), sharey=True)
    t_ms = 1e3 * times
    dynamic_pins = {plate: pin_forces(full.history, plate) for plate in PULLED}
    for ax, pins, what in (
        (axes[0], dynamic_pins, "dynamic, 0.05 mm clearance (FULL)"),
        (axes[1], quasi_pins, "quasi-static, touching pins"),
    ):
        ax.plot(t_ms, 1e-3 * applied, "k--", lw=2, label="applied load")
        for plate, style in (("upper", "-"), ("lower", ":")):
            ax.plot(t_ms, 1e-3 * pins[plate].sum(axis=1), "k" + style, lw=1, label=f"{plate}: all")
            for k in range(PINS):
                ax.plot(t_ms, 1e-3 * pins[plate][:, k], f"C{k}{style}", lw=1, label=f"{plate}: {k}")
        ax.set_title(what, fontsize=10)
        ax.set_xlabel("time [ms]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("force along the plate's load [kN]")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle("Force each plate puts on each pin against the applied load")
    fig.tight_layout()
    fig.savefig(out / "joint_pin_forces.png", dpi=110)
    plt.close(fig)
    compare.step_time_chart(
        out / "joint_step_times.png", [*runs, roundoff], "Pin joint: wall time of each step"
    )
    summary = compare.summary(
        [*runs, roundoff], checks, gflops,
        scale=args.scale, dofs=dofs, steps=args.steps, balance=balance, table=text,
        friction=args.friction, friction_books=friction_lines,
    )  # fmt: skip
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(f"pin joint, scale {args.scale} ({dofs} dofs): {args.steps} steps of {DT * 1e6:g} us")
    print(f"quasi-static balance, each plate: |sum of pin forces - load| / load = {balance:.1e}")
    print(
        f"pictures in {out}/: joint_deformed.png, joint_pressure.png, joint_pressure_3d.png, "
        "joint_contact_strip.png, "
        "joint_pin_forces.png, joint_step_times.png"
    )
    print(f"wall time {time.perf_counter() - start:.1f} s")
    print(text)
    for line in friction_lines:
        print(line)
problem = compare.disagreements(checks)
if friction_failures:
    problem = f"friction's energy books failed: {', '.join(friction_failures)}. {problem or ''}"
if problem:
    raise SystemExit(problem)
# -
