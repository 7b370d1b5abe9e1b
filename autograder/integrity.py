"""Student cells that reach into the grading code, found by reading them (not running).

The hidden tests run in the student's own kernel, after the student's cells, and call
``rosbook.labs.probes`` & co. A cell that rebinds those names, assigns to their attributes
(``checks.assert_sequence = lambda *a: None``), goes through ``setattr``/``sys.modules``
/``builtins``, or hides code in ``exec``/``eval`` could make failing work pass. Nothing
in one kernel can stop that for certain, so the grader reads every cell the student
could edit and flags these patterns for the instructor to review; the score stays
what the checks gave. No solution or plain student code uses them.
"""

from __future__ import annotations

import ast
import importlib.util
import sys
from collections.abc import Iterator

import nbformat

#: Packages whose modules the tests call: a student's cell must not change them.
GRADING_PACKAGES = ("rosbook", "autograder", "nbgrader")
#: Calls that can change or hide anything at run time.
DYNAMIC_CALLS = ("exec", "eval", "compile", "__import__")
#: Calls that change an object given as their first argument.
SETTERS = ("setattr", "delattr", "__setattr__", "__delattr__")


def _grading_module(module: str | None) -> bool:
    return bool(module) and module.split(".")[0] in GRADING_PACKAGES  # type: ignore[union-attr]


def _imported_names(tree: ast.AST) -> set[str]:
    """Names that an import in ``tree`` binds to grading code (``checks``, ``ros``...)."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if _grading_module(alias.name):
                    names.add(alias.asname or alias.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom) and _grading_module(node.module):
            names.update(alias.asname or alias.name for alias in node.names)
    return names


#: ROS 2 Python packages that tutorials import from, installed here or not.
ROS_PACKAGES = ("launch", "launch_ros", "launch_xml", "launch_yaml", "rclpy", "ament_index_python")


def _library_import(node: ast.Import | ast.ImportFrom, alias: ast.alias) -> bool:
    """``from launch import LaunchDescription`` (copied from a ROS tutorial): a name
    imported under its own name from a library (a ROS 2 package, the standard library
    or an installed package, never the student's folder) is honest code. An alias
    (``import os as checks``), a relative import or an unknown module is not."""
    if isinstance(node, ast.ImportFrom) and node.level:
        return False
    if alias.asname not in (None, alias.name.split(".")[-1]):
        return False
    module = node.module if isinstance(node, ast.ImportFrom) else alias.name
    top = (module or "").split(".")[0]
    if top in ROS_PACKAGES or top in sys.stdlib_module_names:
        return True
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return False
    return spec is not None and "site-packages" in (spec.origin or "")


def _root(node: ast.AST) -> str | None:
    """``checks`` for ``checks.a.b``, ``checks.x[0]``, ``checks.f().y``; else None."""
    while isinstance(node, (ast.Attribute, ast.Subscript, ast.Call)):
        node = node.func if isinstance(node, ast.Call) else node.value
    return node.id if isinstance(node, ast.Name) else None


def _targets(node: ast.AST) -> Iterator[ast.AST]:
    if isinstance(node, ast.Assign):
        yield from node.targets
    elif isinstance(node, (ast.AugAssign, ast.AnnAssign, ast.For, ast.AsyncFor)):
        yield node.target
    elif isinstance(node, ast.Delete):
        yield from node.targets
    elif isinstance(node, (ast.With, ast.AsyncWith)):
        yield from (item.optional_vars for item in node.items if item.optional_vars)
    elif isinstance(node, ast.NamedExpr):
        yield node.target


def _flatten(target: ast.AST) -> Iterator[ast.AST]:
    if isinstance(target, (ast.Tuple, ast.List)):
        for element in target.elts:
            yield from _flatten(element)
    elif isinstance(target, ast.Starred):
        yield from _flatten(target.value)
    else:
        yield target


def findings(source: str, protected: set[str]) -> list[tuple[int, str]]:
    """(line, what) for each way ``source`` reaches into the grading code."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return []  # the kernel will say so; nothing in it runs
    protected = protected | _imported_names(tree) | {"rosbook", "builtins", "__builtins__"}
    namespaces = {"globals", "vars", "locals"}  # globals()["checks"] = ... rebinds too
    found = []
    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        for target in (t for top in _targets(node) for t in _flatten(top)):
            root = _root(target)
            if root in protected or root in namespaces:
                what = "rebinds" if isinstance(target, ast.Name) else "changes"
                found.append((line, f"{what} {ast.unparse(target)}"))
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            module = node.module if isinstance(node, ast.ImportFrom) else None
            for alias in node.names:
                bound = alias.asname or alias.name.split(".")[0]
                source_module = module or alias.name
                if (
                    bound in protected - {"builtins"}
                    and not _grading_module(source_module)
                    and not _library_import(node, alias)
                ):
                    found.append((line, f"rebinds {bound} by an import"))
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            if node.name in protected:
                found.append((line, f"rebinds {node.name}"))
        if isinstance(node, ast.Call):
            name = node.func.id if isinstance(node.func, ast.Name) else None
            name = node.func.attr if isinstance(node.func, ast.Attribute) else name
            if name in DYNAMIC_CALLS:
                found.append((line, f"calls {name}()"))
            if name in SETTERS and node.args and _root(node.args[0]) in protected:
                found.append((line, f"calls {name}() on {ast.unparse(node.args[0])}"))
        if isinstance(node, ast.Attribute) and node.attr.startswith("__"):
            if _root(node) in protected:
                found.append((line, f"uses {ast.unparse(node)}"))
        if isinstance(node, ast.Attribute) and node.attr == "modules" and _root(node) == "sys":
            found.append((line, "uses sys.modules"))
        if isinstance(node, ast.Call) and ast.unparse(node.func) in ("importlib.reload", "reload"):
            found.append((line, "reloads a module"))
    return sorted(set(found))


def _python(source: str) -> str | None:
    """The Python of a cell: IPython line magics blanked; ``%%writefile`` body; else None."""
    lines = source.splitlines()
    if lines and lines[0].startswith("%%"):
        if not lines[0].startswith("%%writefile"):
            return None
        lines = lines[1:]
    return "\n".join("" if ln.lstrip().startswith(("%", "!")) else ln for ln in lines)


def _editable(cell: nbformat.NotebookNode) -> bool:
    meta = cell.get("metadata", {}).get("nbgrader", {})
    return cell.cell_type == "code" and (meta.get("solution") or not meta.get("locked"))


def grading_code_changes(
    submitted: nbformat.NotebookNode, released: nbformat.NotebookNode
) -> list[str]:
    """Where the student's editable cells reach into the grading code, one line each."""
    protected: set[str] = set()
    for cell in released.cells:
        if cell.cell_type == "code" and not _editable(cell):
            protected |= _imported_names(ast.parse(_python(cell.source) or ""))
    found = []
    for index, cell in enumerate(submitted.cells):
        if not _editable(cell):
            continue
        python = _python(cell.source)
        if python is None:
            continue
        where = cell.get("metadata", {}).get("nbgrader", {}).get("grade_id") or f"cell {index + 1}"
        for line, what in findings(python, protected):
            code = python.splitlines()[line - 1].strip() if line else ""
            found.append(f"{where}, line {line}: {what} ({code})")
    return found
