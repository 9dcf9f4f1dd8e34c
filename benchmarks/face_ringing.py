"""Is the bar's end face's velocity after the release the face's error or the mesh's?

The bar of ``verify.bar_impact`` (40 and 80 elements, every mass kind, contact_kappa 1 and
the default, CFL 0.1 and 1) with the trapezoidal rule and with generalized-alpha
(rho_inf 0.9, 0.7, 0.5). Per run, from a few steps after the release on: the largest
``|v - v_bar| / v0`` of the end face (massless) and of the node layer behind it (with mass),
``v_bar`` the bar's momentum over its mass. If the face's deviation were its own it would
exceed the layer's and shrink with numerical damping; the semi-discrete mesh's ringing
behind the release wave (a velocity jump) is the same in both and damping at CFL 0.1
leaves it (its frequencies are resolved in time, so not damped).

Writes benchmarks/results/face_ringing.json. Run: python benchmarks/face_ringing.py
"""

from __future__ import annotations

import json
from pathlib import Path

from dd_contact.paper import verify

OUT = Path(__file__).parent / "results" / "face_ringing.json"
SCHEMES = (("trapezoidal", None), ("generalized-alpha", 0.9), ("generalized-alpha", 0.7))
SCHEMES += (("generalized-alpha", 0.5),)


def main() -> None:
    rows = []
    for n in (40, 80):
        for scheme, rho in SCHEMES:
            for mass in ("consistent", "lumped", "averaged"):
                for kappa, cfl in ((1.0, 0.1), (None, 0.1), (1.0, 1.0), (None, 1.0)):
                    r = verify.bar_impact(
                        n=n,
                        cfl=cfl,
                        contact_kappa=kappa,
                        mass=mass,
                        scheme=scheme,
                        rho_infinity=rho,
                    )
                    row = {
                        "n": n,
                        "scheme": scheme,
                        "rho_infinity": rho,
                        "mass": mass,
                        "contact_kappa": kappa,
                        "cfl": cfl,
                        "face_against_bar": r["face_against_bar"],
                        "behind_against_bar": r["behind_against_bar"],
                        "face_tracking": r["face_tracking"],
                        "energy_ratio": r["energy_ratio"],
                    }
                    rows.append(row)
                    print(row, flush=True)
    OUT.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
