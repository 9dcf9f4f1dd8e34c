"""Build the API reference (HTML) from the docstrings with pdoc; exit 1 on any warning.

    python docs/build_api.py [OUTPUT_DIRECTORY]     # default build/api; `make docs` runs it

Every module of the package gets a page (pdoc follows ``__all__``, so a package's
submodules are given one by one). pdoc's warnings (a module that fails to import, a type
annotation it cannot read, a repeated module) are errors here, except one that is pdoc's
and not ours: it cannot read the type parameters of a PEP 695 generic function
(``def f[T](x: T) -> T``) and says so; those are checked to be such parameters and skipped.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
import sys
import warnings
from pathlib import Path

from mpi4py import MPI  # noqa: F401  (libmpi before dolfinx, as in the package)

import pdoc
import pdoc.extract
import pdoc.render

PACKAGE = "dd_contact"
ROOT = Path(__file__).resolve().parents[1]

# pdoc: "Error parsing type annotation T for pkg.mod.func. Import of T failed: ..."
_TYPE_PARAMETER = re.compile(
    r"Error parsing type annotation .* for ([\w.]+)\. Import of (\w+) failed"
)


def modules(package: str = PACKAGE) -> list[str]:
    """The package and its submodules, each once (a package's page may list some already)."""
    names = [package] + [
        m.name
        for m in pkgutil.walk_packages(importlib.import_module(package).__path__, f"{package}.")
    ]
    given, covered = [], set()
    for name in names:
        if name in covered:
            continue
        given.append(name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            covered.update(pdoc.extract.walk_specs([name]))
    return given


def _is_type_parameter(message: str) -> bool:
    """Whether a pdoc warning is about a PEP 695 type parameter of the function it names."""
    match = _TYPE_PARAMETER.search(message)
    if match is None:
        return False
    module_name, _, function_name = match.group(1).rpartition(".")
    function = getattr(importlib.import_module(module_name), function_name, None)
    return match.group(2) in {p.__name__ for p in getattr(function, "__type_params__", ())}


def build(output: Path) -> list[str]:
    """Write the HTML reference to ``output``; return the warnings that are problems."""
    pdoc.render.configure(docformat="google", show_source=True, search=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pdoc.pdoc(*modules(), output_directory=output)
    problems = []
    for w in caught:
        message = str(w.message)
        from_pdoc = Path(w.filename).is_relative_to(Path(pdoc.__file__).parent)
        if from_pdoc and not _is_type_parameter(message):
            problems.append(f"{Path(w.filename).name}:{w.lineno}: {message}")
    return problems


def main(argv: list[str]) -> int:
    """Build into ``argv[0]`` (default build/api) and report; 1 if pdoc warned."""
    output = Path(argv[0]) if argv else ROOT / "build" / "api"
    problems = build(output)
    for problem in problems:
        print(f"warning: {problem}", file=sys.stderr)
    pages = sum(1 for _ in output.rglob("*.html"))
    print(f"API reference: {pages} pages in {output}; {len(problems)} warnings")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
