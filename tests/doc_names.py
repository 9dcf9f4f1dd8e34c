"""Every name the docs give the user, checked against the API (``tests/test_docs.py``).

The code of README.md and docs/*.md, inline spans and ``python`` blocks alike, is parsed
with :mod:`ast`. Each dotted name whose head is ours is resolved attribute by attribute:

* heads: ``dd_contact`` and its aliases ``dc`` and ``dd``, the short name of every module
  of the package (``io``, ``viz``, ``models``, ``schedule``, ...), every class and function
  the package defines (``Subdomain``, ``Interface.from_boundary``), the variables of the
  docs' examples (``problem``, ``scene``, ``sub``: :data:`VARIABLES`), and in a code block
  the variables it assigns from a call it resolves (``steel = dc.Material(...)``);
* attributes: what ``getattr`` finds on the module or class, or what the class's methods
  assign to ``self``; through a property, a call or an attribute assigned to ``self`` the
  check goes on with the type they give (a return annotation, the class called), and stops
  quietly where no type is known;
* keyword arguments of a call that resolves (``TransientProblem(mass="lumped")``,
  ``problem.run(output=...)``) are checked against :func:`inspect.signature`;
* a bare call (``set_body_force(...)``) must name a function, class or method of the
  package, or a Python builtin;
* a bare exception or warning (``InputError``) or constant (``KAPPA_SPLIT``) must be the
  package's (or a builtin, a constant of the tests, an environment variable of the tools,
  a formula's ``D_V``).

Names whose head is not ours (``np.isclose``, ``fem.Constant``, ``x[0]``) are not checked.
"""

from __future__ import annotations

import ast
import builtins
import importlib
import inspect
import pkgutil
import re
import textwrap
import typing
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from types import ModuleType

import dd_contact

#: The variables the docs' examples use without building them, and what they hold.
VARIABLES = {
    "problem": ("StaticProblem", "TransientProblem"),
    "scene": ("Scene",),
    "pressed": ("Scene",),
    "sub": ("Subdomain",),
    "other": ("Subdomain",),
    "block": ("Subdomain",),
    "left": ("Subdomain",),
    "right": ("Subdomain",),
    "iface": ("Interface",),
    "interface": ("Interface",),
    "contact": ("ContactInterface", "ContactBoundary"),
    "bottom": ("ContactInterface",),
    "choice": ("Choice",),
    "iteration": ("ContactIteration",),
}
ALIASES = ("dd_contact", "dc", "dd")
#: Environment variables and C names the docs mention beside the package's constants.
FOREIGN_CONSTANTS = ("DD_", "OMP_", "OPENBLAS_", "MKL_", "PETSC_", "PYVISTA_", "VTK_", "DMUMPS_")
CONSTANT = re.compile(r"[A-Z][A-Z0-9]*_[A-Z0-9_]+|\w+(?:Error|Warning)")
FORMULA = re.compile(r"[A-Z]{1,2}_[A-Z]{1,2}")  # D_V, B_U: the paper's symbols

FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
SPAN = re.compile(r"(`+)(.+?)\1", re.S)
FILE = re.compile(r"[\w./*<>-]+\.(?:md|py|json|png|csv|xdmf|h5|bp|npz|txt|html|msh)\b")
PIECE = re.compile(r"[A-Za-z_][\w.]*(?:\([^()]*\))?")


@dataclass
class Unknown:
    """A value the check cannot type (an unannotated attribute): nothing after it is checked."""


UNKNOWN = Unknown()
DATA = Unknown()  # an attribute known to hold data: calling it is an error


@dataclass
class Report:
    checked: set[str] = field(default_factory=set)  # the names that resolved
    missing: list[str] = field(default_factory=list)  # "page: name (why)"


@cache
def modules() -> dict[str, ModuleType]:
    """Every module of the package by its full name."""
    out = {"dd_contact": dd_contact}
    for info in pkgutil.walk_packages(dd_contact.__path__, "dd_contact."):
        out[info.name] = importlib.import_module(info.name)
    return out


def _ours(obj) -> bool:
    return getattr(obj, "__module__", "").startswith("dd_contact")


@cache
def definitions() -> dict[str, list]:
    """Short name -> the modules, classes and functions of the package of that name."""
    out: dict[str, list] = {}
    for name, module in modules().items():
        out.setdefault(name.rsplit(".", 1)[-1], []).append(module)
        for attr, obj in vars(module).items():
            if (inspect.isclass(obj) or inspect.isfunction(obj)) and _ours(obj):
                if obj.__module__ == module.__name__:
                    out.setdefault(attr, []).append(obj)
    for alias in ALIASES:
        out[alias] = [dd_contact]
    return out


def _classes() -> list[type]:
    return [o for objs in definitions().values() for o in objs if inspect.isclass(o)]


def _self_assignments(cls: type) -> dict[str, list]:
    """Attributes the class's own methods assign to ``self``, with what they hold.

    A class of the package when the value is a call of one or the annotation names one,
    :data:`UNKNOWN` for an annotated callable, :data:`DATA` otherwise (not to be called).
    """
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError, SyntaxError):
        return {}
    namespace = vars(inspect.getmodule(cls))
    out: dict[str, list] = {}
    for node in ast.walk(tree):
        targets, value, annotation = [], None, None
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, ast.AnnAssign):
            targets, value, annotation = [node.target], node.value, node.annotation
        for target in targets:
            for t in target.elts if isinstance(target, ast.Tuple) else [target]:
                if not (isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name)):
                    continue
                if t.value.id != "self":
                    continue
                kinds = out.setdefault(t.attr, [])
                if annotation is not None:
                    text = ast.unparse(annotation)
                    kinds.extend(_annotation_types(text, cls) or [])
                    kinds.append(UNKNOWN if "Callable" in text else DATA)
                elif isinstance(value, ast.Call) and isinstance(value.func, ast.Name):
                    called = namespace.get(value.func.id)
                    if inspect.isclass(called) and _ours(called):
                        kinds.append(called)
    return out


@cache
def instance_attributes(cls: type) -> dict[str, list]:
    """``self.x`` assignments of the class and its bases in the package."""
    out: dict[str, list] = {}
    for base in reversed(cls.__mro__):
        if _ours(base):
            for name, kinds in _self_assignments(base).items():
                out.setdefault(name, []).extend(kinds)
    return out


@cache
def assigned_anywhere() -> dict[str, list]:
    """Attribute name -> the classes assigned to ``self.<name>`` anywhere in the package."""
    out: dict[str, list] = {}
    for cls in _classes():
        for name, kinds in _self_assignments(cls).items():
            out.setdefault(name, []).extend(k for k in kinds if inspect.isclass(k))
    return out


@cache
def constant_names() -> frozenset[str]:
    """The module-level names and class attributes of the package, and the tests' constants."""
    names = set(dir(builtins))
    for module in modules().values():
        names.update(vars(module))
    for cls in _classes():
        names.update(dir(cls))
    tests = Path(__file__).parent
    for path in tests.glob("*.py"):
        names.update(re.findall(r"^([A-Z][A-Z0-9_]*) *[:=]", path.read_text(), re.M))
    return frozenset(names)


def _callable(obj) -> bool:
    methods = (staticmethod, classmethod)
    return inspect.isroutine(obj) or inspect.isclass(obj) or isinstance(obj, methods)


@cache
def callable_names() -> frozenset[str]:
    """Every function, class and method name of the package (what a bare call may name)."""
    names = {n for n, objs in definitions().items() if any(map(_callable, objs))}
    for cls in _classes():
        names.update(n for n, o in vars(cls).items() if _callable(o))
        for base in cls.__mro__:
            if _ours(base):
                names.update(n for n, o in vars(base).items() if _callable(o))
    return frozenset(names)


def annotations(cls: type) -> dict:
    """The annotated attributes of a class and its bases (dataclass fields among them)."""
    out: dict = {}
    for base in reversed(cls.__mro__):
        out.update(getattr(base, "__annotations__", {}))
    return out


def methods_named(name: str) -> list:
    """The methods of that name of every class of the package (a bare ``run(...)``)."""
    return [getattr(c, name) for c in _classes() if _callable(vars(c).get(name))]


def _annotation_types(annotation, owner) -> list:
    """The package's classes an annotation names (``X``, ``X | None``)."""
    if isinstance(annotation, str):
        namespace = vars(inspect.getmodule(owner)) if inspect.getmodule(owner) else {}
        try:
            annotation = eval(annotation, dict(namespace))  # the package's own annotations
        except Exception:
            return []
    if inspect.isclass(annotation) and _ours(annotation):
        return [annotation]
    return [a for a in typing.get_args(annotation) if inspect.isclass(a) and _ours(a)]


def _returns(func) -> list:
    """What calling ``func`` gives: a class -> its instance (the class), else the annotation."""
    if inspect.isclass(func):
        return [func]
    try:
        annotation = inspect.signature(func).return_annotation
    except (TypeError, ValueError):
        return []
    return [] if annotation is inspect.Signature.empty else _annotation_types(annotation, func)


def attribute(candidates: list, name: str) -> list | None:
    """``name`` looked up on each candidate: what it gives, or None if none has it."""
    found: list = []
    for obj in candidates:
        if isinstance(obj, ModuleType) or inspect.isclass(obj):
            try:
                static = inspect.getattr_static(obj, name)
            except AttributeError:
                if inspect.isclass(obj) and name in annotations(obj):
                    found.extend(_annotation_types(annotations(obj)[name], obj) or [UNKNOWN])
                    continue
                if inspect.isclass(obj) and name in instance_attributes(obj):
                    kinds = instance_attributes(obj)[name]
                    classes = [k for k in kinds if inspect.isclass(k)]
                    found.extend(classes or kinds or assigned_anywhere().get(name) or [UNKNOWN])
                    continue
                if isinstance(obj, ModuleType) and f"{obj.__name__}.{name}" in modules():
                    found.append(modules()[f"{obj.__name__}.{name}"])
                continue
            if isinstance(static, property):
                kinds = _returns(static.fget) if static.fget else []
                found.extend(kinds or [UNKNOWN])
            elif isinstance(static, (staticmethod, classmethod)):
                found.append(getattr(obj, name))
            elif inspect.isfunction(static) or inspect.isclass(static):
                found.append(static)
            elif isinstance(static, ModuleType):
                found.append(static)
            elif hasattr(type(static), "__get__") and _ours(type(static)):
                found.extend(assigned_anywhere().get(name) or [UNKNOWN])  # a descriptor
            elif inspect.isclass(obj) and name in annotations(obj):
                found.extend(_annotation_types(annotations(obj)[name], obj) or [static])
            else:
                found.append(static)  # a constant: its own attributes are checked
        elif isinstance(obj, Unknown) or inspect.isfunction(obj):
            found.append(UNKNOWN)  # a function's attributes are not the docs' business
        elif hasattr(obj, name):
            found.append(getattr(obj, name))
    return found or None


def _accepts(func, keyword: str) -> bool | None:
    """Whether ``func`` takes ``keyword``; None when that cannot be told."""
    try:
        parameters = inspect.signature(func).parameters
    except (TypeError, ValueError):
        return None
    p = parameters.get(keyword)
    if p is not None:
        return p.kind is not inspect.Parameter.POSITIONAL_ONLY
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        owner = getattr(func, "__self__", None)  # a classmethod passing **kwargs on to cls
        return _accepts(owner, keyword) if inspect.isclass(owner) else None
    return False


class Checker(ast.NodeVisitor):
    """Resolves the names of one piece of code; records them in a :class:`Report`."""

    def __init__(self, report: Report, where: str, variables: dict[str, list]):
        self.report, self.where, self.variables = report, where, variables

    def _head(self, name: str) -> list | None:
        if name in self.variables:
            return self.variables[name]
        if name in VARIABLES:
            kinds = [c for n in VARIABLES[name] for c in definitions().get(n, [])]
            return kinds + definitions().get(name, [])
        return definitions().get(name)

    def _miss(self, text: str, why: str) -> None:
        self.report.missing.append(f"{self.where}: {text} ({why})")

    def value(self, node) -> list | None:
        """The candidates an expression gives, None if it is not ours (or already failed)."""
        if isinstance(node, ast.Name):
            return self._head(node.id)
        if isinstance(node, ast.Attribute):
            base = self.value(node.value)
            if base is None:
                return None
            if all(isinstance(b, Unknown) for b in base):
                return base
            found = attribute(base, node.attr)
            text = ast.unparse(node)
            if found is None:
                self._miss(text, "no such attribute")
                return None
            self.report.checked.add(text)
            return found
        if isinstance(node, ast.Call):
            funcs = self.value(node.func)
            self._arguments(node)
            if funcs is None:
                if isinstance(node.func, ast.Name):
                    if not self._known_bare(node.func.id):
                        self._miss(ast.unparse(node.func), "not a name of the package")
                    self._keywords(node, methods_named(node.func.id))  # run(output=...)
                return None
            if all(f is DATA for f in funcs):
                self._miss(ast.unparse(node.func), "an attribute, not a method")
                return None
            self._keywords(node, funcs)
            out = [r for f in funcs for r in (_returns(f) if callable(f) else [])]
            return out or [UNKNOWN]
        if isinstance(node, ast.Subscript):
            self.value(node.value)
            self.visit(node.slice)
            return None
        self.visit(node)
        return None

    def _known_bare(self, name: str) -> bool:
        if len(name) <= 2:
            return True  # a formula's r(t0), g(t): not code
        if name in dir(builtins) or name in callable_names():
            self.report.checked.add(f"{name}()")
            return True
        return False

    def _keywords(self, node: ast.Call, funcs: list) -> None:
        callables = [f for f in funcs if callable(f) and not isinstance(f, Unknown)]
        for kw in node.keywords:
            if kw.arg is None or not callables:
                continue
            verdicts = [_accepts(f, kw.arg) for f in callables]
            if any(verdicts) or all(v is None for v in verdicts):
                self.report.checked.add(f"{ast.unparse(node.func)}({kw.arg}=)")
            else:
                self._miss(f"{ast.unparse(node.func)}({kw.arg}=...)", "no such keyword")

    def _arguments(self, node: ast.Call) -> None:
        for arg in node.args:
            self.visit(arg)
        for kw in node.keywords:
            self.visit(kw.value)

    def visit_Attribute(self, node):
        self.value(node)

    def visit_Call(self, node):
        self.value(node)

    def visit_Subscript(self, node):
        self.value(node)

    def visit_Assign(self, node):
        kinds = self.value(node.value)
        for target in node.targets:
            if isinstance(target, ast.Name):
                self.variables[target.id] = kinds or [UNKNOWN]  # the example's own variable
            else:
                self.visit(target)

    def visit_With(self, node):
        for item in node.items:
            kinds = self.value(item.context_expr)
            if isinstance(item.optional_vars, ast.Name) and kinds:
                self.variables[item.optional_vars.id] = kinds
        for statement in node.body:
            self.visit(statement)

    def visit_Name(self, node):
        """A bare constant or exception (``KAPPA_SPLIT``, ``InputError``) is the package's."""
        name = node.id
        if not CONSTANT.fullmatch(name) or name in self.variables:
            return
        if name.startswith(FOREIGN_CONSTANTS) or FORMULA.fullmatch(name):
            return
        if name in constant_names():
            self.report.checked.add(name)
        else:
            self._miss(name, "not a name of the package")

    def visit_Import(self, node):
        pass

    def visit_ImportFrom(self, node):
        """``from dd_contact.x import y`` binds y; an import of a missing name fails."""
        if not (node.module or "").startswith("dd_contact"):
            return
        module = modules().get(node.module)
        if module is None:
            self._miss(node.module, "no such module")
            return
        for alias in node.names:
            found = attribute([module], alias.name)
            if found is None:
                self._miss(f"{node.module}.{alias.name}", "no such attribute")
            else:
                self.report.checked.add(f"{node.module}.{alias.name}")
                self.variables[alias.asname or alias.name] = found


def _parse(code: str) -> list[ast.AST]:
    """The code as a module, or its name-like pieces that parse (a span of prose or shell)."""
    code = FILE.sub("_file_", code)
    try:
        return [ast.parse(code)]
    except SyntaxError:
        pass
    out = []
    for piece in PIECE.findall(code):
        try:
            out.append(ast.parse(piece.rstrip(".")))
        except SyntaxError:
            continue
    return out


def code_of(text: str) -> tuple[list[str], list[str]]:
    """(python blocks, inline spans) of a Markdown page; other blocks are left out."""
    blocks = [body for lang, body in FENCE.findall(text) if lang == "python"]
    prose = FENCE.sub("", text)
    spans = [m.group(2).strip() for m in SPAN.finditer(prose) if "\n\n" not in m.group(2)]
    return blocks, spans


def check_text(text: str, where: str, report: Report | None = None) -> Report:
    """Check every name in a Markdown text; the blocks of a page share their variables."""
    report = report or Report()
    blocks, spans = code_of(text)
    variables: dict[str, list] = {}
    for block in blocks:
        for tree in _parse(block):
            Checker(report, where, variables).visit(tree)
    for span in spans:
        for tree in _parse(span):
            Checker(report, where, {}).visit(tree)
    return report


def check_pages(pages: list[Path]) -> Report:
    report = Report()
    for page in pages:
        check_text(page.read_text(), page.name, report)
        check_commands(page.read_text(), page.name, report)
    return report


COMMAND = re.compile(r"dd-contact((?: +--?[a-z][\w-]*| +[a-z][\w-]*)+)")


def commands_of(text: str) -> list[tuple[str, list[str]]]:
    """``dd-contact SUB --option ...`` in a page's code: (sub-command, its options)."""
    blocks, spans = code_of(text)
    indented = re.findall(r"^(?: {4}|\t)(.*)$", FENCE.sub("", text), re.M)
    out = []
    for code in [*blocks, *spans, *indented]:
        for match in COMMAND.finditer(code):
            words = match.group(1).split()
            if words[0].startswith("-"):
                out.append(("", words[:1]))
            else:
                out.append((words[0], [w for w in words[1:] if w.startswith("--")]))
    return out


def command_help(words: tuple[str, ...]) -> str | None:
    """``dd-contact WORDS --help`` as text, None if argparse refuses the words."""
    import contextlib
    import io

    from dd_contact import cli

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        try:
            cli.main([*words, "--help"])
        except SystemExit as done:
            if done.code != 0:
                return None
    return out.getvalue()


def check_commands(text: str, where: str, report: Report) -> Report:
    """Each ``dd-contact`` sub-command the text names exists and takes the options given."""
    for command, options in commands_of(text):
        help_text = command_help((command,) if command else ())
        if help_text is None:
            report.missing.append(f"{where}: dd-contact {command} (no such command)")
            continue
        report.checked.add(f"dd-contact {command}".rstrip())
        for option in options:
            named = " ".join(filter(None, ["dd-contact", command, option]))
            if re.search(rf"{re.escape(option)}\b", help_text):
                report.checked.add(named)
            else:
                report.missing.append(f"{where}: {named} (no such option)")
    return report
