"""Every public callable (a name in ``drivelash.__all__``, ``drivelash.params.__all__`` or a
subpackage's ``__all__``, and the public methods its classes define) has a docstring whose
numpydoc ``Parameters`` section names exactly the parameters of its signature — none missing,
none that does not exist; and every unskipped docstring example runs.

A class's constructor parameters may be documented under ``Parameters`` or ``Attributes`` (a
result dataclass documents its fields as attributes). ``numpydoc`` is not a dependency: the
section parser is a small one here (``python tests/test_public_api_docs.py`` lists violations).
"""

from __future__ import annotations

import ast
import builtins
import dataclasses
import doctest
import importlib
import inspect
import pkgutil
import re
import textwrap
import types
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import drivelash
import drivelash.errors
from drivelash.errors import ParameterError

_SECTION = re.compile(r"^(\s*)([A-Z][A-Za-z ]+)\n\1-{3,}\s*$", re.MULTILINE)
_ENTRY = re.compile(r"^([*\w][\w, *]*?)\s*(?::.*)?$")


def sections(doc: str | None) -> dict[str, list[str]]:
    """numpydoc section name → the names its entries document (``a, b : float`` gives both)."""
    text = inspect.cleandoc(doc or "")
    found = list(_SECTION.finditer(text))
    out: dict[str, list[str]] = {}
    for i, m in enumerate(found):
        body = text[m.end() : found[i + 1].start() if i + 1 < len(found) else len(text)]
        indent = m.group(1)
        names: list[str] = []
        for line in body.splitlines():
            if not line.strip() or not line.startswith(indent) or line[len(indent) :].startswith((" ", "\t")):
                continue  # blank, or a description line (indented under its entry)
            entry = _ENTRY.match(line[len(indent) :].rstrip())
            if entry:
                names += [n.strip().lstrip("*") for n in entry.group(1).split(",") if n.strip()]
        out[m.group(2).strip()] = names
    return out


def signature_names(obj: Callable[..., object]) -> list[str] | None:
    """The parameters a docstring must document (``self``/``cls`` left out); None when the
    signature cannot be read."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return None
    return [p for p in sig.parameters if p not in ("self", "cls")]


def parameter_problems(
    obj: Callable[..., object], *, constructor: bool = False, require_section: bool = False
) -> list[str]:
    """What is wrong with ``obj``'s docstring: missing, a ``Parameters`` entry that is not a
    parameter, a parameter with no entry once the docstring has a ``Parameters`` section (or
    always, with ``require_section``). For a class (``constructor``) the signature is the
    constructor's and ``Attributes`` entries count as documented."""
    doc = obj.__doc__ if constructor else inspect.getdoc(obj)
    if not (doc and doc.strip()):
        return ["no docstring"]
    params = signature_names(obj)
    if params is None:
        return []
    secs = sections(doc)
    documented = secs.get("Parameters", []) + secs.get("Other Parameters", [])
    problems = [f"documents {n!r}, not a parameter" for n in documented if n not in params]
    if constructor:
        documented = documented + secs.get("Attributes", [])
    if not documented and not (require_section and params):
        return problems  # prose documentation (a one-line method, a record described in words)
    return problems + [f"parameter {p!r} not documented" for p in params if p not in documented]


def public_packages() -> Iterator[types.ModuleType]:
    """The curated namespaces: the top level, ``drivelash.params`` (the parameter classes) and
    every subpackage with an ``__all__`` (tests/identify/test_api.py: each has one)."""
    yield drivelash
    yield importlib.import_module("drivelash.params")
    for info in pkgutil.walk_packages(drivelash.__path__, "drivelash."):
        if info.ispkg:
            mod = importlib.import_module(info.name)
            if hasattr(mod, "__all__"):
                yield mod


def listed(pkg: types.ModuleType, name: str) -> object:
    """``pkg.name``; a submodule listed in ``__all__`` (``drivelash.te``) is imported."""
    if not hasattr(pkg, name):
        return importlib.import_module(f"{pkg.__name__}.{name}")
    return getattr(pkg, name)


def public_callables() -> dict[str, tuple[Callable[..., object], bool]]:
    """``qualified name → (object, is a class)`` for every callable in an ``__all__`` and
    every public method a public class defines (its own, not inherited from outside)."""
    out: dict[str, tuple[Callable[..., object], bool]] = {}
    for pkg in public_packages():
        for name in pkg.__all__:
            obj = listed(pkg, name)
            if isinstance(obj, types.ModuleType) or not callable(obj):
                continue
            key = f"{obj.__module__}.{obj.__qualname__}"
            if inspect.isclass(obj):
                out[key] = (obj, True)
                for attr, member in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    func = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
                    if inspect.isfunction(func) and func.__module__.startswith("drivelash"):
                        out[f"{key}.{attr}"] = (getattr(obj, attr), False)
            else:
                out[key] = (obj, False)
    return out


PUBLIC = public_callables()


def _required(obj: object, is_class: bool) -> bool:
    """Whether ``obj`` must have a Parameters (or, for a record, Attributes) section: every
    public function and method, and every class but a typing.Protocol (never constructed)."""
    return not (is_class and getattr(obj, "_is_protocol", False))


@pytest.mark.parametrize("name", sorted(PUBLIC))
def test_public_docstring_parameters(name: str) -> None:
    """Every public callable documents exactly its parameters in numpydoc form; a class its
    constructor's, under Parameters or, for a record, Attributes."""
    obj, is_class = PUBLIC[name]
    assert parameter_problems(obj, constructor=is_class, require_section=_required(obj, is_class)) == []


def test_every_all_name_exists() -> None:
    """Each ``__all__`` lists only names that exist (a submodule is imported) and are public."""
    for pkg in public_packages():
        for name in pkg.__all__:
            assert not name.startswith("_") or name == "__version__", (pkg.__name__, name)
            listed(pkg, name)  # AttributeError / ImportError: listed but not there


def raised_errors(func: Callable[..., object]) -> set[str]:
    """Exception classes ``func`` raises by name in its own body (``raise ParameterError(...)``;
    not in nested functions, not re-raised variables)."""
    func = getattr(func, "py_func", func)  # a numba kernel: its Python source
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    except (OSError, TypeError, SyntaxError):
        return set()
    names: set[str] = set()
    scopes = [getattr(func, "__globals__", {}), vars(drivelash.errors), vars(builtins)]

    def visit(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda | ast.ClassDef):
                continue
            if isinstance(child, ast.Raise) and child.exc is not None:
                exc = child.exc.func if isinstance(child.exc, ast.Call) else child.exc
                if isinstance(exc, ast.Name):
                    cls = next((sc[exc.id] for sc in scopes if exc.id in sc), None)
                    if isinstance(cls, type) and issubclass(cls, BaseException):
                        names.add(exc.id)
            visit(child)

    visit(tree.body[0])
    return names


@pytest.mark.parametrize("name", sorted(n for n, (o, c) in PUBLIC.items() if _required(o, c)))
def test_raised_errors_are_documented(name: str) -> None:
    """An error a public callable raises itself is named in its Raises section (a class: its
    ``__init__`` and a dataclass's ``__post_init__``, the validation of its fields)."""
    obj, is_class = PUBLIC[name]
    if is_class:
        raised = raised_errors(obj.__init__)  # type: ignore[misc]
        if "__post_init__" in vars(obj):
            raised |= raised_errors(vars(obj)["__post_init__"])
    else:
        raised = raised_errors(obj)
    assert raised - set(sections(obj.__doc__).get("Raises", [])) == set()


def _examples() -> dict[str, doctest.DocTest]:
    """The docstring examples of the public callables (``Examples`` sections), by name."""
    finder = doctest.DocTestFinder(recurse=False)
    tests = {}
    for name, (obj, _) in PUBLIC.items():
        module = inspect.getmodule(obj)  # the example sees its module's names, as in the docs
        for test in finder.find(obj, name, module=module, globs=dict(vars(module))):
            if test.examples:
                tests[name] = test
    return tests


EXAMPLES = _examples()


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_docstring_examples_run(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A public docstring's example runs and prints what it says (from the repository root:
    the examples name repository files, ``examples/drive_bench.toml``)."""
    monkeypatch.chdir(Path(__file__).resolve().parents[1])
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    result = runner.run(EXAMPLES[name])
    assert result.failed == 0, result


def test_examples_were_found() -> None:
    """Negative control of the example test: the examples are collected and none is skipped,
    and a wrong printed value fails."""
    run = ("estimation.backlash_api.estimate_backlash", "control.cascade.CascadeController",
           "estimation.estimator.DeadzoneEstimator")  # fmt: skip
    for name in (f"drivelash.{n}" for n in run):
        assert not any(ex.options.get(doctest.SKIP) for ex in EXAMPLES[name].examples), name
    wrong = doctest.DocTestParser().get_doctest(">>> 1 + 1\n3\n", {}, "wrong", None, 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert runner.run(wrong, out=lambda _: None).failed == 1  # a wrong printed value fails


def test_checker_catches_a_wrong_docstring() -> None:
    """Negative control: a documented parameter that is not in the signature, one that is
    missing, a missing docstring, a record's undocumented field and an error raised by name
    are each seen."""

    def wrong(T_s: float, delta: float) -> float:
        """Something.

        Parameters
        ----------
        dt : float
            Sample period [s].
        delta : float
            Backlash [rad].
        """
        return T_s * delta

    def bare(x: float) -> float:
        return x

    def right(T_s: float, *args: float, delta1: float = 0.0, **kw: float) -> float:
        """Something.

        Parameters
        ----------
        T_s : float
            Sample period [s].
        *args : float
            More.
        delta1 : float, optional
            Offset [rad].

            Indented text : not an entry.
        **kw
            Rest.

        Returns
        -------
        out : float
            Product [rad·s].
        """
        return T_s

    assert parameter_problems(wrong) == ["documents 'dt', not a parameter", "parameter 'T_s' not documented"]
    assert parameter_problems(bare) == ["no docstring"]
    assert parameter_problems(right) == []
    assert parameter_problems(bare.__call__) == []  # no signature to check: not a false alarm
    bare.__doc__ = "One line.\n\nReturns\n-------\nfloat\n    [rad]."
    assert parameter_problems(bare) == []  # prose only: consistent, but ...
    assert parameter_problems(bare, require_section=True) == ["parameter 'x' not documented"]  # ... required

    @dataclasses.dataclass
    class Record:
        """A result.

        Attributes
        ----------
        delta : float
            Deadzone [rad].
        """

        delta: float
        T_s: float

    assert parameter_problems(Record, constructor=True) == ["parameter 'T_s' not documented"]
    Record.__doc__ = "A result: δ [rad] and T_s [s] in prose."
    assert parameter_problems(Record, constructor=True) == []
    assert parameter_problems(Record, constructor=True, require_section=True) == [
        "parameter 'delta' not documented",
        "parameter 'T_s' not documented",
    ]

    def refuses(T_s: float) -> float:
        """Something.

        Parameters
        ----------
        T_s : float
            Sample period [s].
        """
        if not T_s > 0:
            raise drivelash.errors.ParameterError("x", "T_s", "must be > 0")  # attribute: not seen
        if T_s > 1:
            raise ParameterError("x", "T_s", "must be <= 1 s")
        return T_s

    assert raised_errors(refuses) == {"ParameterError"}
    refuses.__doc__ += "\n    Raises\n    ------\n    ParameterError\n        Not in (0, 1] s.\n"
    assert set(sections(refuses.__doc__)["Raises"]) == {"ParameterError"}


if __name__ == "__main__":  # the list of violations, for fixing them
    for name, (obj, is_class) in sorted(PUBLIC.items()):
        required = _required(obj, is_class)
        for problem in parameter_problems(obj, constructor=is_class, require_section=required):
            print(f"{name}: {problem}")
