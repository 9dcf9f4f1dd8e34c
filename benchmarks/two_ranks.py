"""w-v-u on 1 and 2 MPI ranks: speed-up per step and per contact change (issue 14 item 5).

The 306k-dof bar of ``benchmarks/decomposition_speed.py`` (``examples.parallelepiped``,
250 x 36 x 10 hexahedra cut 1:1, pressed on a tilted wall, dt = 1 us), run by
``benchmarks/paper_scale.py``'s worker under ``mpiexec -n 1`` and ``-n 2``: on two ranks
each rank owns one subdomain (factorised, condensed and substituted there) and rank 0 the
dense surface system. Every BLAS pinned to one thread, so the two ranks use the two cores.
The parent samples the memory of the whole process tree and the load average.

Writes benchmarks/results/two_ranks.json after every run (resumes from it): per run the
worker's record (set-up, every step and contact iteration, peak memory per rank) and the
summary with the speed-ups 1 rank / 2 ranks per step (without its change iterations), per
change and of the set-up.

``weak_scaling`` adds a model of a bar of P such subdomains on P machines (a subdomain per
machine, each on a sub-communicator; docs/solvers.md "A subdomain larger than one machine"):
per step the measured subdomain work of one rank (constant under weak scaling) plus the dense
surface system of the P - 1 interfaces and the contact interface, priced with this machine's
measured dense rates (``dd_contact.timing``), solved on one core (today's engine) or spread
over the P machines (ScaLAPACK, at an assumed 50 % parallel efficiency).

Run: python benchmarks/two_ranks.py [--elements 250,36,10] [--steps 8] [--repeats 1]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from paper_scale import derived
from pinned import PINNED
from process_watch import timed_run

HERE = Path(__file__).parent / "results"
MPIEXEC = Path(sys.executable).with_name("mpiexec")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--elements", default="250,36,10", help="nx,ny,nz")
    parser.add_argument("--steps", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--memory-limit", type=float, default=14.0, help="GiB, whole tree")
    parser.add_argument("--out", default=str(HERE / "two_ranks.json"))
    args = parser.parse_args()
    out = Path(args.out)
    data = json.loads(out.read_text()) if out.exists() else {}
    if data.get("elements") != args.elements:
        data = {"elements": args.elements}
    runs = data.setdefault("runs", {})
    env = {**os.environ, **PINNED}
    worker = Path(__file__).with_name("paper_scale.py")
    for repeat in range(args.repeats):
        for ranks in (1, 2):
            key = f"{ranks}|{repeat}"
            if key in runs and "failed" not in runs[key]:
                continue
            command = [str(MPIEXEC), "-n", str(ranks), sys.executable, str(worker)]
            command += ["--worker", "w-v-u", "--model", "bar", "--scale", args.elements]
            command += ["--steps", str(args.steps), "--dt", "1e-6"]
            print(f"{ranks} rank(s), run {repeat + 1}: running", flush=True)
            log = out.with_name(f"two_ranks_{ranks}.log")
            runs[key] = timed_run(command, env, args.memory_limit, log)
            data["summary"] = summary(runs)
            data["weak_scaling"] = weak_scaling(data["summary"], runs)
            out.write_text(json.dumps(data, indent=1))
            print(json.dumps(data["summary"]), flush=True)


def summary(runs: dict) -> dict:
    """Per rank count the median run's derived values; the speed-ups 1 rank / 2 ranks."""
    out: dict = {}
    for ranks in (1, 2):
        done = [r for k, r in runs.items() if k.startswith(f"{ranks}|") and "steps" in r]
        if done:
            pick = sorted(done, key=lambda r: derived(r)["seconds_per_step"])[len(done) // 2]
            out[f"{ranks}_ranks"] = {
                **derived(pick),
                "runs": len(done),
                "peak_rss_gib_per_rank": pick["peak_rss_gib"],
                "peak_tree_rss_gib": pick["peak_tree_rss_gib"],
                "load_average_mean": pick["load_average_mean"],
            }
    one, two = out.get("1_ranks"), out.get("2_ranks")
    if one and two:
        out["speed_up"] = {
            key: one[key] / two[key]
            for key in ("seconds_per_step", "seconds_per_change", "setup_seconds")
            if one.get(key) and two.get(key)
        }
    return out


def weak_scaling(summary: dict, runs: dict, efficiency: float = 0.5) -> dict | None:
    """Per-step and set-up seconds of P subdomains on P machines (a model; see the docstring)."""
    one = summary.get("1_ranks")
    if not one:
        return None
    from dd_contact import timing

    blocks = next(r["blocks"] for r in runs.values() if "blocks" in r)
    interface = next(n for b, n in blocks.items() if b.startswith("v:"))
    contact = sum(n for b, n in blocks.items() if b.startswith("w:"))
    subdomains = sum(1 for b in blocks if b.startswith("u:"))
    rates = timing.machine_rates()
    sub_step = one["seconds_per_step"] / subdomains  # one subdomain's share of a step
    sub_setup = one["setup_seconds"] / subdomains
    rows = []
    for machines in (2, 8, 32, 128):
        m = (machines - 1) * interface + contact  # the dense surface system
        factor = rates.seconds("dense_factor", m**3 / 3.0)
        solve = rates.seconds("dense_solve", 2.0 * m * m)
        spread = machines * efficiency
        rows.append(
            {
                "machines": machines,
                "dofs": machines * (sum(blocks.values()) - contact) // subdomains,
                "surface_dofs": m,
                "step_one_core_s": sub_step + solve,
                "step_scalapack_s": sub_step + solve / spread,
                "setup_one_core_s": sub_setup + factor,
                "setup_scalapack_s": sub_setup + factor / spread,
                "step_efficiency_scalapack": sub_step / (sub_step + solve / spread),
            }
        )
    return {
        "subdomain_step_s": sub_step,
        "subdomain_setup_s": sub_setup,
        "interface_dofs": interface,
        "contact_dofs": contact,
        "parallel_efficiency_assumed": efficiency,
        "rows": rows,
    }


if __name__ == "__main__":
    main()
