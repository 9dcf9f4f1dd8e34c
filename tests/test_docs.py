"""The docs: every relative link resolves inside the repository, every name in their code is
the API's (``doc_names``), the README's code runs; the API reference builds."""

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import doc_names
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
# [text](target) in Markdown, and file names in backticks such as `docs/solvers.md`.
MARKDOWN_LINK = re.compile(r"\]\(([^)\s]+)\)")
CODE_PATH = re.compile(r"`([\w./-]+\.(?:md|py|json|png))`")


def _relative_links(page: Path) -> list[str]:
    links = [t.split("#")[0] for t in MARKDOWN_LINK.findall(page.read_text())]
    return [t for t in links if t and not re.match(r"[a-z]+:", t)]


def test_pages_found():
    assert len(PAGES) >= 9  # README and the docs, method.md among them
    assert ROOT / "docs" / "method.md" in PAGES


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_links_resolve_in_repository(page):
    for target in _relative_links(page):
        resolved = (page.parent / target).resolve()
        assert resolved.is_relative_to(ROOT), f"{page.name}: {target} leaves the repository"
        assert resolved.exists(), f"{page.name}: {target} does not exist"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_named_files_exist(page):
    """A file named in backticks exists: beside the page, from the root, in docs/ or the package."""
    for name in CODE_PATH.findall(page.read_text()):
        if "/" not in name and name.endswith((".json", ".png")):
            continue  # an output file name (history.json, tied_bar.png), not a repository path
        places = [page.parent / name, ROOT / name, ROOT / "docs" / name, ROOT / "dd_contact" / name]
        if any(p.resolve().is_relative_to(ROOT) and p.exists() for p in places):
            continue
        outputs = ("demo_output/", "results/", "build/", "out/")
        assert name.startswith(outputs), f"{page.name}: `{name}` not found in the repository"


# A section named after a page: `docs/solvers.md`, "Loads" or [contact.md](contact.md), "Impact"
# or docs/contact.md "Impact" (text may wrap across lines).
SECTION_REFERENCE = re.compile(
    r"(?:docs/)?([\w-]+\.md)`?(?:\]\([^)]*\))?[,;]?\s+[\"“]([^\"”]{3,80})[\"”]"
)
SOURCES = [
    *PAGES,
    *sorted((ROOT / "dd_contact").rglob("*.py")),
    *sorted((ROOT / "demos").glob("*.py")),
    *sorted((ROOT / "benchmarks").glob("*.py")),
]


def _section_references(text: str) -> list[tuple[str, str]]:
    text = re.sub(r"\n[ \t]*#:?", "\n", text)  # a reference in comments that wrap
    return [(page, " ".join(title.split())) for page, title in SECTION_REFERENCE.findall(text)]


def _flat(text: str) -> str:
    return " ".join(text.replace("*", "").replace("`", "").split()).lower()


def _titles(text: str) -> list[str]:
    """What a section can be named by: headings, bold lead-ins and table header rows."""
    text = PYTHON_BLOCK.sub("", text)
    headings = re.findall(r"^#+ (.*)$", text, re.M)
    bold = re.findall(r"\*\*(.+?)\*\*", text, re.S)
    headers = re.findall(r"(?:^|\n\n)(\|.*\|)\n\|[-| ]+\|", text)
    return [_flat(t) for t in [*headings, *bold, *headers]]


def test_named_sections_exist():
    """A page and section named together (``docs/contact.md``, "Impact") is a heading, a bold
    lead-in or a table header of that page: moving text must not leave a reference behind."""
    missing, found = [], 0
    for source in SOURCES:
        for page, title in _section_references(source.read_text()):
            target = ROOT / "docs" / page if page != "README.md" else ROOT / page
            if not target.exists():
                continue  # a page that does not exist is test_links_resolve's to report
            found += 1
            if not any(_flat(title) in t for t in _titles(target.read_text())):
                missing.append(f'{source.relative_to(ROOT)}: {page}, "{title}"')
    assert not missing, "sections that are not where they are said to be:\n" + "\n".join(missing)
    assert found >= 40


def test_section_check_reads_references():
    text = (
        'see (`docs/solvers.md`, "Loads") and [contact.md](contact.md), "A time step\n  too coarse"'
    )
    text += ' and docs/contact.md "Impact".'
    assert _section_references(text) == [
        ("solvers.md", "Loads"),
        ("contact.md", "A time step too coarse"),
        ("contact.md", "Impact"),
    ]


def test_link_check_finds_a_broken_link(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("See [the method](../shared/method.md) and [x](https://example.org).")
    assert _relative_links(page) == ["../shared/method.md"]


def _build_script():
    spec = importlib.util.spec_from_file_location("build_api", ROOT / "docs" / "build_api.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _python(*args, cwd=None) -> subprocess.CompletedProcess:
    """Run this interpreter on ``args`` with this checkout first on the path (10 min at most)."""
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, *args],
        cwd=cwd,
        env=dict(os.environ, PYTHONPATH=path),
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def test_api_reference_builds_without_warnings(tmp_path):
    pytest.importorskip("pdoc")
    done = _python(ROOT / "docs" / "build_api.py", tmp_path / "api")
    assert done.returncode == 0, done.stderr[-3000:]
    pages = {p.relative_to(tmp_path / "api").as_posix() for p in (tmp_path / "api").rglob("*.html")}
    # One page per module: the package, its subpackages and their modules.
    modules = {
        p.relative_to(ROOT).with_suffix(".html").as_posix().replace("/__init__.html", ".html")
        for p in (ROOT / "dd_contact").rglob("*.py")
    }
    assert modules <= pages
    assert "0 warnings" in done.stdout
    viz = (tmp_path / "api" / "dd_contact" / "viz.html").read_text()
    assert "plot_contact_pressure" in viz and "UNIFORM_RTOL" in viz


def test_build_skips_only_type_parameters():
    pytest.importorskip("pdoc")
    build = _build_script()
    pep695 = (
        "Error parsing type annotation T for dd_contact.parallel.bcast_from_root. "
        "Import of T failed: name 'T' is not defined"
    )
    other = (
        "Error parsing type annotation Foo for dd_contact.parallel.bcast_from_root. "
        "Import of Foo failed: name 'Foo' is not defined"
    )
    assert build._is_type_parameter(pep695)
    assert not build._is_type_parameter(other)
    assert not build._is_type_parameter("Cannot find spec for dd_contact.nothing")


PYTHON_BLOCK = re.compile(r"```python\n(.*?)```", re.S)


def test_readme_python_blocks_run_as_written(tmp_path):
    """The README's python blocks, in order, as one script: they run and print what they say."""
    blocks = PYTHON_BLOCK.findall((ROOT / "README.md").read_text())
    assert len(blocks) == 4  # first model, steps in time, two meshes, one mesh decomposed
    script = tmp_path / "readme.py"
    script.write_text("\n".join(blocks))
    done = _python(script, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.splitlines()
    force = np.array(lines[0].strip("[]").split(), dtype=float)
    assert force[2] == pytest.approx(4.5e7, rel=0.01)  # "about (0, 0, 4.5e7) N"
    assert float(lines[1]) == pytest.approx(1.0)  # the whole face in contact
    t, force = lines[2].split(" ", 1)
    assert float(t) == pytest.approx(1.0) and float(force.strip("[]").split(",")[2]) > 0
    contact, reaction = (np.array(v.split(), dtype=float) for v in lines[3][1:-1].split("] ["))
    assert contact[2] > 0 and reaction[2] > 0  # the support and the clamp share the load
    assert contact[2] + reaction[2] == pytest.approx(1e5, rel=1e-5)  # round-off of kappa 1e6
    assert "w:under" in done.stdout and "v:interface" in done.stdout  # the work table
    # the one mesh decomposed: the tip in a small part, auto picks w-v-u, the support carries
    # the hand-built scene's force (other meshes: 45,557 N against 45,406 N)
    assert "contact part x > 7.25: 176 of 640 cells" in done.stdout
    chosen, force = re.search(r"^([a-zA-Z-]+) \[(.*)\]$", done.stdout, re.M).groups()
    assert chosen == "w-v-u"
    assert float(force.split()[2]) == pytest.approx(contact[2], rel=0.01)
    results = tmp_path / "results"
    written = ["history.json", "history.csv", "u_pressed.xdmf", "w_face.xdmf"]
    for name in [*written, "checkpoint.rank0.npz", "block.png"]:
        assert (results / name).exists(), name
    assert len((results / "history.csv").read_text().splitlines()) == 1 + 10  # header, steps


def test_complete_examples_in_the_guides_run(tmp_path):
    """A python block of docs/*.md that starts with ``from mpi4py import MPI`` is a whole
    script: it runs as written."""
    blocks = [
        (page.name, block)
        for page in PAGES[1:]
        for block in PYTHON_BLOCK.findall(page.read_text())
        if block.startswith("from mpi4py import MPI")
    ]
    # decompose.md: one mesh decomposed; guide.md: the tied cantilever with dolfinx objects
    assert [name for name, _ in blocks] == ["decompose.md", "guide.md"]
    for name, block in blocks:
        script = tmp_path / "example.py"
        script.write_text(block)
        done = _python(script, cwd=tmp_path)
        assert done.returncode == 0, f"{name}: {done.stderr[-3000:]}"
    reaction = np.array(done.stdout.splitlines()[0].strip("[]").split(), dtype=float)
    assert reaction[2] == pytest.approx(1e5, rel=1e-5)  # the clamp carries the 100 kN tip load
    assert (tmp_path / "results" / "u_left.bp").exists()


def test_readme_is_for_users_first():
    """The README leads with install, a first model and results; the measurements live in
    docs/benchmarks.md and docs/validation.md."""
    text = (ROOT / "README.md").read_text()
    headings = re.findall(r"^## (.*)$", text, re.M)
    assert headings[:3] == ["Install", "A first model", "Steps in time, and the output directory"]
    assert "Reading results" in headings and "Which algorithm fits which scene" in headings
    assert len(text.splitlines()) <= 180
    assert text.count("\n|") <= 12  # one table: which algorithm fits which scene


def test_method_names_every_equation_and_the_code_that_implements_it():
    """docs/method.md section 9: a row for each of (1)-(17) and (A1)-(A21), each naming
    dd_contact objects that import."""
    text = (ROOT / "docs" / "method.md").read_text().split("## 9.")[1]
    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| \((A?\d+)\) \|(.*)$", text, re.M)}
    assert set(rows) == {str(k) for k in range(1, 18)} | {f"A{k}" for k in range(1, 22)}
    names = set(re.findall(r"`(dd_contact\.[\w.]+)`", text))
    assert len(names) >= 30
    for name in sorted(names):
        parts = name.split(".")
        for cut in range(len(parts), 0, -1):  # the longest importable module, then attributes
            try:
                obj = importlib.import_module(".".join(parts[:cut]))
            except ImportError:
                continue
            for attribute in parts[cut:]:
                obj = getattr(obj, attribute)
            break
        else:
            raise AssertionError(f"{name} does not import")


def test_every_name_in_the_docs_is_the_apis():
    """Each dd_contact name, keyword and ``dd-contact`` command in the docs' code exists."""
    report = doc_names.check_pages(PAGES)
    assert not report.missing, "names the API does not have:\n" + "\n".join(report.missing)
    assert len(report.checked) >= 330  # the check resolves names, it does not skip them


WRONG_NAMES = """
Loads: `set_body_force(lambda t: (0, 0, -9.81))`, not `body_force(lambda t: (0, 0, -9.81))`;
`sub.body_force(f)` is an attribute; `TransientProblem(scene, dt, masss="lumped")`,
`problem.run(10, outptu="out")`, `dc.Nope`, `io.write_vtk(scene, "out")`,
`problem.iteration.release_solve`, `Interface.from_boundary(sub, where, [sub], kapa=1e6)`,
`dd-contact verfy` and `dd-contact calibrate --shwo`, `KAPPA_SPLITT`, `InacurateSolutionError`;
fine: `OMP_NUM_THREADS`, `D_V`, `RuntimeError`, `np.isclose(x[0], 0)`,
`fem.Constant(mesh, 0.0)`, `viz.plot_deformed(scene, "a.png")`, `problem.choice.table()`.

```python
from dd_contact import ioo
steel = dc.Material(E=210e9, nu=0.3, rhoo=7850.0)
left = dc.Subdomain(mesh, steel, "left")
left.fixx(lambda x: x[0] < 1e-9)
```
"""


def test_a_wrong_name_in_the_docs_is_found():
    report = doc_names.check_text(WRONG_NAMES, "page")
    doc_names.check_commands(WRONG_NAMES, "page", report)
    assert sorted(report.missing) == sorted(
        f"page: {m}"
        for m in [
            "body_force (not a name of the package)",
            "sub.body_force (an attribute, not a method)",
            "TransientProblem(masss=...) (no such keyword)",
            "problem.run(outptu=...) (no such keyword)",
            "dc.Nope (no such attribute)",
            "io.write_vtk (no such attribute)",
            "problem.iteration.release_solve (no such attribute)",
            "Interface.from_boundary(kapa=...) (no such keyword)",
            "dd_contact.ioo (no such attribute)",
            "dc.Material(rhoo=...) (no such keyword)",
            "left.fixx (no such attribute)",
            "dd-contact verfy (no such command)",
            "dd-contact calibrate --shwo (no such option)",
            "KAPPA_SPLITT (not a name of the package)",
            "InacurateSolutionError (not a name of the package)",
        ]
    )
    assert {"set_body_force()", "viz.plot_deformed", "problem.choice.table"} <= report.checked
