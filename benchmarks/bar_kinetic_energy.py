"""Which kinetic energy of the bar impact is closer to the truth: the user's or the package's?

The bar of ``verify.bar_impact`` (nu = 0, c = 1, L = 1) starts on a rigid wall at v0. The 1-D
closed form: a compression wave leaves the wall at c, the struck part stands still, so
``KE(t) = E0 (1 - c t / L)`` in the first transit, ``E0 (c t / L - 1)`` in the second (the
unloading wave sends the bar back at -v0) and ``E0`` after the release. Per run (elements,
mass kind, contact_kappa, CFL): the largest and the mean ``|KE - KE_exact| / E0`` over the
first transit, and the largest once the bar has left (t > 2.2 L / c), of the kinetic energy a
user integrates from ``Subdomain.velocity`` with the true density (the wall's mass where it
belongs) and of the package's own (its walls massless, their mass spread over the bar).

Writes benchmarks/results/bar_kinetic_energy.json. Run: python benchmarks/bar_kinetic_energy.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from dd_contact.paper import verify
from dd_contact.paper.verify import bar

OUT = Path(__file__).parent / "results" / "bar_kinetic_energy.json"


def energies(**options) -> tuple[np.ndarray, np.ndarray, float]:
    """The user's and the package's kinetic energy after each step, and E0."""
    kept = {}
    summary = bar._EndFaceWatch.summary

    def keep(watch, v0, energy0, settle):
        kept["rows"], kept["E0"] = np.array(watch.rows), energy0
        return summary(watch, v0, energy0, settle)

    bar._EndFaceWatch.summary = keep  # the watch's rows, read once the run ends
    try:
        verify.bar_impact(**options)
    finally:
        bar._EndFaceWatch.summary = summary
    return kept["rows"][:, 3], kept["rows"][:, 4], kept["E0"]


def main() -> None:
    out = []
    for n in (40, 80):
        for mass in ("consistent", "lumped", "averaged"):
            for kappa in (1.0, None):
                for cfl in (0.1, 0.5, 1.0):
                    user, package, e0 = energies(n=n, cfl=cfl, contact_kappa=kappa, mass=mass)
                    t = cfl / n * np.arange(1, len(user) + 1)
                    exact = e0 * np.where(t < 2.0, np.abs(1.0 - t), 1.0)
                    first, after = t < 1.0, t > 2.2
                    row = {"n": n, "mass": mass, "contact_kappa": kappa, "cfl": cfl}
                    for name, ke in (("user", user), ("package", package)):
                        error = np.abs(ke - exact) / e0
                        row[f"{name}_first_max"] = float(error[first].max())
                        row[f"{name}_first_mean"] = float(error[first].mean())
                        row[f"{name}_after_max"] = float(error[after].max())
                    row["user_vs_package"] = float(np.abs(user - package).max() / e0)
                    out.append(row)
                    print(row, flush=True)
    OUT.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
