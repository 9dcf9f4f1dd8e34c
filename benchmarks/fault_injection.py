"""Runs ended at random steps by SIGTERM, SIGKILL and a full disk, then resumed (issue 31).

Every trial runs a small model to ``STEPS`` steps (checkpoints every ``CHECKPOINT_EVERY``,
fields every step) in a fresh directory, ends it at a random step, and runs the same
script again with ``resume=True`` (after a full disk: once the space is free again). It
passes if the resumed run ends as the uninterrupted reference run of the same case, to the
last bit (FULL on more than one rank: to :data:`ROUNDOFF`, see :func:`reproducible`;
``--launches N`` measures how often N uninterrupted launches of each case differ):

* every subdomain's final u equal (``np.array_equal``), also as :func:`load_results` gives
  it back at the last step;
* ``history.json`` the reference's (every step once, equal records) and ``history.csv`` the
  same text;
* every field series' index parses and lists steps 0 ... STEPS once each, every step's
  file reads and equals the reference's (every field, bit for bit); meshio's XDMF reader
  reads every step, and pyvista's (in a subprocess: a crash fails the check, not the script)
  opens the last trial of each case and mode;
* no temporary (``*.tmp``) or set-aside (``*.damaged``) file left.

Modes: ``sigterm`` and ``sigkill`` are sent to the whole process group (mpiexec and its
ranks, as a batch scheduler does) a random time after the run has written the row of a
random step; ``disk`` writes to a small tmpfs (mounted here when root and ``mount`` works)
filled by a file that leaves a random part of the run's output room; the run must stop
with one ``OutputError``, the filler is removed and the run resumed. Where no tmpfs can be
mounted, ``disk`` injects the failure instead: the k-th file the output opens for writing
(k random) raises ``OSError(ENOSPC)`` (``--inject``).

Cases: the README's pressed block, quasi-static (FULL and w-u; ``pressed``), and two such
blocks side by side, a body each, one tilted as it is pressed, so its contact area grows
(``pressed-pair``); two blocks flying at a wall, the contact area growing and shrinking
(``dd_contact.paper.verify.order_scene``, with inertia): an interface and a contact
interface (``flying``: FULL, v-w-u, w-v-u), and an interface with contact on a block's own
boundary (``flying-boundary``: v-u). Each on 1 and 2 ranks (``mpiexec -n 2``; on 2 ranks the
one-subdomain ``pressed`` leaves a rank without a subdomain).

Writes benchmarks/results/fault_injection.json: per mode and ranks the trials and passes (in
all and per case: the trials take the cases in turn), and every failure's reason.

Run: python benchmarks/fault_injection.py [--trials 10] [--modes sigterm,sigkill,disk]
     [--ranks 1,2] [--cases pressed:FULL,...] [--seed 1]
"""

from __future__ import annotations

import argparse
import errno
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "fault_injection.json"
MPIEXEC = Path(sys.executable).with_name("mpiexec")
STEPS = 12
CHECKPOINT_EVERY = 3
CASES = (
    "pressed:FULL",
    "pressed:w-u",
    "pressed-pair:FULL",
    "pressed-pair:w-u",
    "flying:FULL",
    "flying:v-w-u",
    "flying:w-v-u",
    "flying-boundary:v-u",
)
#: Exit status of a run ended by a full disk (the worker's OutputError).
DISK_FULL = 3


# -- the worker: one run of one case ------------------------------------------------------------
def _scene(model: str):
    from mpi4py import MPI

    import dd_contact as dc
    from dd_contact import meshes
    from dd_contact.paper.verify import order_scene

    def pressed(name: str, x0: float, tilt: float, gap: float):
        """The README's pressed block at x0, its top pushed down (and tilted) in time."""
        steel = dc.Material(E=210e9, nu=0.3, rho=7850.0)
        box = meshes.box(MPI.COMM_SELF, [x0, 0, 0], [x0 + 1, 1, 0.5], [4, 4, 2])
        block = dc.Subdomain(box, steel, name)
        block.fix(
            lambda x: np.isclose(x[2], 0.5),
            value=lambda x, t: np.vstack(
                [0 * x[0], 0 * x[0], -1e-4 * t * (1 + tilt * (x[0] - x0 - 0.5))]
            ),
        )
        plane = dc.Plane([0, 0, -gap], [0, 0, 1])
        bottom = dc.ContactInterface.from_boundary(
            block, lambda x: np.isclose(x[2], 0.0), plane, name=f"bottom_{name}"
        )
        return block, bottom

    if model.startswith("pressed"):  # one block, or two side by side (a body each)
        parts = [pressed("block", 0.0, 0.0, 0.0)]
        if model == "pressed-pair":
            parts.append(pressed("other", 2.0, 1.5, 2e-5))
        blocks, contacts = zip(*parts, strict=True)
        scene = dc.Scene(MPI.COMM_WORLD, list(blocks), contacts=list(contacts))
        return scene, {"dt": 0.1, "inertia": False}
    kind = {"flying": "interface", "flying-boundary": "boundary"}[model]
    return order_scene(kind, True, 1e4), {"dt": 0.01}


class _FailingFile:
    """A file whose writes fail as on a full disk (after the first, which goes through)."""

    def __init__(self, file):
        self._file, self._writes = file, 0

    def write(self, data):
        self._writes += 1
        if self._writes > 1:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return self._file.write(data[: len(data) // 2])

    def __getattr__(self, name):
        return getattr(self._file, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._file.close()


def _inject_full_disk(after: int) -> None:
    """The ``after``-th file the run's output writes fails half way as on a full disk.

    Counted: the step files, the series' indexes and mesh files, the history files (each
    row of ``history.csv``) and the checkpoints, at the places the package opens them.
    """
    import builtins

    import dd_contact.checkpointing
    import dd_contact.io
    import dd_contact.series
    from dd_contact.writing import append_or_undo, failure, replace_atomically

    count = [0]

    def due() -> bool:
        count[0] += 1
        return count[0] == after

    def replaced(path, write, what, directory=None):
        if due():
            return replace_atomically(path, lambda f: write(_FailingFile(f)), what, directory)
        return replace_atomically(path, write, what, directory)

    def appended(path, data, what):
        if due():
            raise failure(OSError(errno.ENOSPC, "full"), what, path.parent)
        return append_or_undo(path, data, what)

    def opened(file, mode="r", *args, **kwargs):
        real = builtins.open(file, mode, *args, **kwargs)
        return _FailingFile(real) if "w" in mode and due() else real

    dd_contact.io.replace_atomically = replaced
    dd_contact.series.replace_atomically = replaced
    dd_contact.io.append_or_undo = appended
    dd_contact.checkpointing.open = opened  # type: ignore[attr-defined]


def worker(case: str, out: str, resume: bool, inject: int | None) -> int:
    """One run of ``case`` into ``out``: 0 when it ends, 143 stopped, 3 a full disk."""
    from mpi4py import MPI

    import dd_contact as dc

    model, algorithm = case.split(":")
    if inject:
        _inject_full_disk(inject)
    scene, settings = _scene(model)
    problem = dc.TransientProblem(scene, algorithm=algorithm, **settings)
    try:
        problem.run(
            STEPS,
            output=out,
            checkpoint_every=CHECKPOINT_EVERY,
            resume=resume,
            progress=False,
            summary=False,
        )
    except dc.OutputError as error:
        if MPI.COMM_WORLD.rank == 0:
            print(f"OutputError: {error}", file=sys.stderr)
        return DISK_FULL
    if MPI.COMM_WORLD.rank == 0:
        final = {s.name: s.u.x.array for s in scene.subdomains}
        np.savez(Path(out).parent / f"{Path(out).name}.final.npz", **final)
    return 0


# -- the parent: trials and checks --------------------------------------------------------------
def _command(case: str, out: Path, ranks: int, resume: bool, inject: int | None = None):
    command = [sys.executable, __file__, "--worker", case, str(out)]
    command += ["--resume"] if resume else []
    command += ["--inject", str(inject)] if inject else []
    return [str(MPIEXEC), "-n", str(ranks), *command] if ranks > 1 else command


def _environment() -> dict[str, str]:
    root = str(HERE.parent)
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": f"{root}:{path}" if path else root}


def _run(command, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        command, env=_environment(), capture_output=True, text=True, timeout=timeout
    )


def _rows(path: Path) -> int:
    try:
        return max(path.read_bytes().count(b"\n") - 1, 0)
    except OSError:
        return 0


def _interrupted(case: str, out: Path, ranks: int, signum: int, rng: random.Random) -> tuple:
    """Run and send ``signum`` to the process group after a random step; (rc, step, stderr)."""
    step = rng.randint(1, STEPS - 2)
    process = subprocess.Popen(
        _command(case, out, ranks, resume=False),
        env=_environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 300
    while process.poll() is None and _rows(out / "history.csv") < step:
        if time.monotonic() > deadline:
            break
        time.sleep(0.002)
    time.sleep(rng.uniform(0.0, 0.03))  # somewhere in the next step: solving or writing
    if process.poll() is None:
        os.killpg(process.pid, signum)
    _, stderr = process.communicate(timeout=300)
    return process.returncode, step, stderr


def _mount_tmpfs(path: Path, size: int) -> bool:
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    path.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True,
        check=False,
    )
    return done.returncode == 0


def _size(directory: Path) -> int:
    return sum(p.stat().st_size for p in directory.rglob("*") if p.is_file())


def _full_disk(case, base: Path, ranks, reference: Path, rng, inject: bool) -> tuple:
    """Run on a disk that fills (or an injected failure), then free it; (rc, detail, stderr)."""
    if inject:
        after = rng.randint(3, 40)
        done = _run(_command(case, base / "out", ranks, False, inject=after))
        return done.returncode, f"failure injected at the {after}-th file", done.stderr, None
    disk = base / "disk"
    total = _size(reference) + (1 << 20)
    if not _mount_tmpfs(disk, total + (1 << 20)):
        raise RuntimeError("no tmpfs")
    filler = disk / "filler"
    room = int(_size(reference) * rng.uniform(0.15, 0.9))
    with open(filler, "wb") as f:
        f.write(b"\0" * max(total + (1 << 20) - room, 0))
    done = _run(_command(case, disk / "out", ranks, resume=False))
    filler.unlink()
    return done.returncode, f"{room} bytes of room", done.stderr, disk


def reproducible(case: str, ranks: int) -> bool:
    """Whether two uninterrupted launches of ``case`` give the same bits.

    Not FULL on more than one rank: MUMPS's distributed factorisation hands work to the
    processes by their load as it goes, so sums are taken in another order in some
    launches (``--launches`` measures how often). Its resumed runs are judged to
    :data:`ROUNDOFF` of each quantity's magnitude; every other case bit for bit.
    """
    return ranks == 1 or not case.endswith(":FULL")


#: Round-off allowed where launches differ (:func:`reproducible`), relative to the largest
#: magnitude of the array or history record compared.
ROUNDOFF = 1e-9


def _agree(a, b, exact: bool) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if exact or a.dtype.kind != "f" or a.shape != b.shape:
        return a.shape == b.shape and bool(np.array_equal(a, b))
    scale = float(np.abs(b).max(initial=0.0))
    return float(np.abs(a - b).max(initial=0.0)) <= ROUNDOFF * scale


def _leaves(record, path: str = "") -> list[tuple[str, object]]:
    if isinstance(record, dict):
        return [leaf for k in sorted(record) for leaf in _leaves(record[k], f"{path}.{k}")]
    if isinstance(record, list):
        return [leaf for i, v in enumerate(record) for leaf in _leaves(v, f"{path}[{i}]")]
    return [(path, record)]


def _records_agree(a: list, b: list, exact: bool) -> bool:
    """History records equal: counts and names exactly, floats as :func:`_agree` says."""
    if exact or len(a) != len(b):
        return a == b
    for x, y in zip(a, b, strict=True):
        mine, theirs = _leaves(x), _leaves(y)
        if [p for p, _ in mine] != [p for p, _ in theirs]:
            return False
        values = [(u, v) for (_, u), (_, v) in zip(mine, theirs, strict=True)]
        if any(type(u) is not float and u != v for u, v in values):
            return False
        pairs = [(u, v) for u, v in values if type(u) is float]
        if pairs and not _agree([u for u, _ in pairs], [v for _, v in pairs], exact=False):
            return False
    return True


def _csv_rows(path: Path) -> list:
    def value(text: str):
        try:
            return int(text)
        except ValueError:
            try:
                return float(text)
            except ValueError:
                return text

    return [[value(t) for t in line.split(",")] for line in path.read_text().splitlines()]


def _fields_equal(out: Path, reference: Path, exact: bool = True) -> str | None:
    """Why the field series of ``out`` differ from the reference's (``None``: they do not)."""
    import h5py

    from dd_contact.series import read_index, step_file

    for index in sorted(reference.glob("*.xdmf")):
        mine = out / index.name
        try:
            ET.parse(mine)
            steps = read_index(mine)
        except (OSError, ET.ParseError, ValueError) as error:
            return f"{index.name}: {error}"
        if list(steps) != list(range(STEPS + 1)):
            return f"{index.name} lists steps {list(steps)}"
        for step in steps:
            with (
                h5py.File(out / index.stem / step_file(step), "r") as a,
                h5py.File(reference / index.stem / step_file(step), "r") as b,
            ):
                for name in b:
                    if not _agree(a[name][()], b[name][()], exact):
                        return f"{index.stem} step {step}: {name} differs"
    return None


def _meshio_reads(out: Path) -> str | None:
    try:
        import meshio
    except ImportError:
        return None
    for index in sorted(out.glob("*.xdmf")):
        with meshio.xdmf.TimeSeriesReader(index) as reader:
            reader.read_points_cells()
            for k in range(reader.num_steps):
                reader.read_data(k)
            if reader.num_steps != STEPS + 1:
                return f"meshio reads {reader.num_steps} steps of {index.name}"
    return None


PYVISTA_CHECK = """
import sys, pyvista
for path in sys.argv[1:]:
    reader = pyvista.get_reader(path)
    names = set()
    for t in reader.time_values:
        reader.set_active_time_value(t)
        mesh = reader.read()
        assert mesh.n_points > 0, path
        names |= set(mesh.array_names)
    print(len(reader.time_values), ",".join(sorted(names)))
"""


def pyvista_fields(out: Path) -> dict[str, tuple[int, list[str]]]:
    """Per series of ``out``: the steps and fields pyvista reads (in a subprocess).

    Raises ``RuntimeError`` if pyvista fails or crashes (a crash ends only the subprocess).
    """
    paths = sorted(out.glob("*.xdmf"))
    env = {**_environment(), "PYVISTA_OFF_SCREEN": "true"}
    done = subprocess.run(
        [sys.executable, "-c", PYVISTA_CHECK, *map(str, paths)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"pyvista: rc {done.returncode}: {done.stderr[-300:]}")
    lines = [line.split(" ") for line in done.stdout.splitlines()]
    return {p.stem: (int(n), names.split(",")) for p, (n, names) in zip(paths, lines, strict=True)}


def pyvista_reads(out: Path, steps: int = STEPS) -> str | None:
    """Why pyvista cannot open every series of ``out`` at steps 0 ... ``steps``."""
    try:
        found = pyvista_fields(out)
    except RuntimeError as error:
        return str(error)
    wrong = {stem: n for stem, (n, names) in found.items() if n != steps + 1 or not names}
    return f"pyvista reads {wrong} steps" if wrong else None


def check(out: Path, final: Path, reference: Path, exact: bool = True) -> str | None:
    """Why the resumed run in ``out`` differs from the reference (``None``: it does not).

    ``exact``: bit for bit; otherwise to :data:`ROUNDOFF` (:func:`reproducible`).
    """
    import dd_contact as dc

    got, expected = np.load(final), np.load(reference.parent / f"{reference.name}.final.npz")
    for name in expected.files:
        if not _agree(got[name], expected[name], exact):
            return f"final u of {name} differs"
    history = json.loads((out / "history.json").read_text())
    if [r["step"] for r in history] != list(range(1, STEPS + 1)):
        return f"history steps {[r['step'] for r in history]}"
    if not _records_agree(history, json.loads((reference / "history.json").read_text()), exact):
        return "history.json differs"
    mine, theirs = out / "history.csv", reference / "history.csv"
    if exact and mine.read_text() != theirs.read_text():  # the same text, to the last digit
        return "history.csv differs"
    if not exact and not _records_agree(_csv_rows(mine), _csv_rows(theirs), exact):
        return "history.csv differs"
    left = [p.name for p in out.rglob("*") if p.name.endswith((".tmp", ".damaged"))]
    if left:
        return f"left behind: {left}"
    loaded = dc.load_results(out)
    for name in expected.files:
        u = loaded.arrays(STEPS, f"u_{name}")
        want = dc.load_results(reference).arrays(STEPS, f"u_{name}")
        if not _agree(u[f"u_{name}"], want[f"u_{name}"], exact):
            return f"load_results: u_{name} differs"
    return _fields_equal(out, reference, exact) or _meshio_reads(out)


def _launch_spread(case: str, ranks: int, reference: Path, launches: int) -> dict:
    """``launches`` uninterrupted runs of ``case`` (the reference one of them): how many
    ended with other bits than the reference, and their largest difference relative to
    the largest displacement."""
    expected = np.load(reference.parent / f"{reference.name}.final.npz")
    differ, largest = 0, 0.0
    for k in range(1, launches):
        again = reference.parent / f"{reference.name}_launch{k}"
        if _run(_command(case, again, ranks, resume=False)).returncode != 0:
            raise RuntimeError(f"launch {k} of {case} failed")
        got = np.load(again.parent / f"{again.name}.final.npz")
        gaps = [np.abs(got[n] - expected[n]).max() / np.abs(expected[n]).max() for n in got.files]
        differ += any(not np.array_equal(got[n], expected[n]) for n in got.files)
        largest = max(largest, float(max(gaps)))
        shutil.rmtree(again, ignore_errors=True)
    return {"launches": launches, "differ_from_the_first": differ, "largest_relative": largest}


def trial(case, mode, ranks, base: Path, reference: Path, rng, inject) -> dict:
    """One interrupted and resumed run; its record (``passed`` and what happened)."""
    out, disk = base / "out", None
    if mode == "disk":
        rc, detail, stderr, disk = _full_disk(case, base, ranks, reference, rng, inject)
        out = disk / "out" if disk else out
        expected = (DISK_FULL, 0)  # 0: the room sufficed (the whole run fit)
        once = stderr.count("OutputError") <= 1 and "Traceback" not in stderr
    else:
        signum = signal.SIGTERM if mode == "sigterm" else signal.SIGKILL
        rc, step, stderr = _interrupted(case, out, ranks, signum, rng)
        detail = f"signal after step {step}"
        expected = (128 + signum, -signum, 0) if mode == "sigterm" else (-signum, 137, 0)
        once = "Traceback" not in stderr
    record = {"mode": mode, "ranks": ranks, "case": case, "detail": detail, "rc": rc}
    try:
        if rc not in expected or not once:
            record["passed"], record["why"] = False, f"rc {rc}: {stderr[-600:]}"
            return record
        again = _run(_command(case, out, ranks, resume=True))
        record["resumed_rc"] = again.returncode
        if again.returncode != 0:
            record["passed"], record["why"] = False, again.stderr[-600:]
            return record
        exact = reproducible(case, ranks)
        why = check(out, out.parent / f"{out.name}.final.npz", reference, exact)
        record["passed"], record["why"] = why is None, why
        record["compared"] = "bit for bit" if exact else f"to {ROUNDOFF:g} of each magnitude"
        record["out"] = str(out)
        return record
    finally:
        if disk is not None:
            subprocess.run(["umount", str(disk)], check=False, capture_output=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--trials", type=int, default=12, help="per mode and ranks")
    parser.add_argument("--modes", default="sigterm,sigkill,disk")
    parser.add_argument("--ranks", default="1,2")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--launches",
        type=int,
        default=1,
        help="uninterrupted launches of each case (>= 2: how often they differ)",
    )
    parser.add_argument("--inject", action="store_true", help="full disk by injection")
    parser.add_argument("--out", default=str(RESULTS))
    parser.add_argument("--worker", nargs=2, metavar=("CASE", "OUT"), help=argparse.SUPPRESS)
    parser.add_argument("--resume", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--inject-at", type=int, default=None, help=argparse.SUPPRESS)
    args, _ = parser.parse_known_args()
    if args.worker:
        inject = None
        if "--inject" in sys.argv:
            inject = int(sys.argv[sys.argv.index("--inject") + 1])
        sys.exit(worker(*args.worker, args.resume, inject))
    rng = random.Random(args.seed)
    inject = args.inject
    records = []
    started = time.perf_counter()
    work = Path(tempfile.mkdtemp(prefix="fault_injection_"))
    try:
        for ranks in [int(r) for r in args.ranks.split(",")]:
            if ranks > 1 and not MPIEXEC.exists():
                continue
            cases = args.cases.split(",")
            references = {}
            for case in cases:
                reference = work / f"reference_{ranks}_{case.replace(':', '_')}"
                done = _run(_command(case, reference, ranks, resume=False))
                if done.returncode != 0:
                    raise RuntimeError(f"reference run of {case}: {done.stderr[-2000:]}")
                references[case] = reference
                if args.launches > 1:
                    spread = _launch_spread(case, ranks, reference, args.launches)
                    records.append({"launches": spread, "ranks": ranks, "case": case})
                    print(json.dumps(records[-1]), flush=True)
            for mode in args.modes.split(","):
                last = None
                for k in range(args.trials):  # the cases in turn
                    case = cases[k % len(cases)]
                    base = work / f"{ranks}_{case.replace(':', '_')}_{mode}_{k}"
                    base.mkdir()
                    try:
                        record = trial(case, mode, ranks, base, references[case], rng, inject)
                    except RuntimeError as error:  # no tmpfs here: inject instead
                        if mode != "disk" or inject:
                            raise
                        print(f"{error}: the full disk is injected from now on")
                        inject = True
                        record = trial(case, mode, ranks, base, references[case], rng, inject)
                    record["full_disk"] = "injected" if inject else "tmpfs"
                    last = record.pop("out", None) or last
                    records.append(record)
                    print(json.dumps(record), flush=True)
                why = pyvista_reads(Path(last)) if last else "no trial ended"
                records.append({"mode": mode, "ranks": ranks, "pyvista": why is None})
                if why:
                    print(why, flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    summary: dict[str, dict] = {}
    for r in records:
        if "passed" not in r:
            continue
        entry = summary.setdefault(
            f"{r['mode']} / {r['ranks']} rank(s)",
            {"trials": 0, "passed": 0, "by_case": {}, "failures": []},
        )
        entry["trials"] += 1
        entry["passed"] += bool(r["passed"])
        case = entry["by_case"].setdefault(r["case"], [0, 0])
        case[0] += 1
        case[1] += bool(r["passed"])
        if not r["passed"]:
            entry["failures"].append(r)
    pyvista = {f"{r['mode']} / {r['ranks']}": r["pyvista"] for r in records if "pyvista" in r}
    report = {
        "steps": STEPS,
        "checkpoint_every": CHECKPOINT_EVERY,
        "seconds": round(time.perf_counter() - started, 1),
        "trials": sum(e["trials"] for e in summary.values()),
        "passed": sum(e["passed"] for e in summary.values()),
        "by_mode_and_ranks": summary,  # by_case: [trials, passed]
        "pyvista_opens_every_step": pyvista,
        "records": [r for r in records if "passed" in r],
        "launches": [r for r in records if "launches" in r],
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1) + "\n")
    print(f"{report['passed']} of {report['trials']} trials passed; {out}")


if __name__ == "__main__":
    main()
