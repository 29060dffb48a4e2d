"""The layout of ``costa.discover`` is its design: routes over a shared core.

Read from the source with :mod:`ast` (nothing is imported): the shared core imports no route,
the full-state and the sparse route do not import each other (nor the glue above them), the
sparse route's two ways of deciding a round (``sparse/filter``, ``sparse/shooting``) import
neither each other nor the glue that picks between them, and no module imports another module's
private name from the package.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "costa.discover"

#: what each folder of the package may import from the package (besides itself); the top-level
#: modules are the glue that picks a route and writes the findings, and may import anything.
#: ``sparse``: the sparse route's shared layer (its top-level modules but :data:`SPARSE_GLUE`)
ALLOWED = {
    "core": {"core"},
    "full_state": {"core", "full_state"},
    "sparse": {"core", "sparse"},
    "sparse/filter": {"core", "sparse", "sparse/filter"},
    "sparse/shooting": {"core", "sparse", "sparse/shooting"},
    "sparse/glue": {"core", "sparse", "sparse/filter", "sparse/shooting", "sparse/glue"},
    "cases": {"core", "cases"},
}
#: the sparse route's modules that pick how a round is decided and write its jobs' records
SPARSE_GLUE = {"pipeline", "split"}


def _module_name(path: Path, src: Path) -> str:
    parts = path.relative_to(src).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, src: Path = SRC) -> list[tuple[int, str, str | None]]:
    """(line, imported module, imported name or None) of every import in ``path`` (a file under
    ``src``), relative imports resolved; ``from . import x`` yields the module ``<package>.x`` too."""
    name = _module_name(path, src)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[: len(package.split(".")) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            for alias in node.names:
                found.append((node.lineno, module, alias.name))
                found.append((node.lineno, f"{module}.{alias.name}", None))  # the name may be a submodule
    return found


def area(module: str) -> str | None:
    """The folder of ``costa.discover`` a module lies in ("" for the top level), None outside it."""
    if module != PACKAGE and not module.startswith(PACKAGE + "."):
        return None
    rest = module[len(PACKAGE) + 1 :].split(".")
    if rest[0] == "sparse" and len(rest) > 1:
        if f"sparse/{rest[1]}" in ALLOWED:
            return f"sparse/{rest[1]}"
        return "sparse/glue" if rest[1] in SPARSE_GLUE else "sparse"
    return rest[0] if rest[0] in ALLOWED else ""


def layout_violations(src: Path = SRC) -> list[str]:
    """Every import from a folder of the package into a folder it may not import."""
    violations = []
    for path in sorted((src / Path(*PACKAGE.split("."))).rglob("*.py")):
        source = area(_module_name(path, src))
        if not source:
            continue
        reported = set()
        for line, module, _ in imports(path, src):
            target = area(module)
            if target is not None and target != source and target not in ALLOWED[source]:
                if (line, target) not in reported:  # one line, one report: its module, not each name
                    reported.add((line, target))
                    where = f"{path.relative_to(src)}:{line}"
                    violations.append(f"{where}: {source}/ imports {module} ({target or 'the top level'})")
    return violations


def private_imports(src: Path = SRC) -> list[str]:
    """Every ``from costa.discover... import _name`` in the library: private names stay in their module."""
    found = []
    for path in sorted((src / "costa").rglob("*.py")):
        for line, module, name in imports(path, src):
            if name and name.startswith("_") and area(module) is not None:
                found.append(f"{path.relative_to(src)}:{line}: imports {name} from {module}")
    return found


def test_the_package_has_the_folders_the_check_knows():
    root = SRC / Path(*PACKAGE.split("."))
    folders = {p.parent.relative_to(root).as_posix() for p in root.rglob("*/__init__.py")}
    assert folders == set(ALLOWED) - {"sparse/glue"}
    for folder in folders:  # each says which route it is and what it reads and writes
        assert ast.get_docstring(ast.parse((root / folder / "__init__.py").read_text())), folder


def test_the_core_imports_no_route_and_the_routes_not_each_other():
    assert layout_violations() == []


def test_no_private_name_is_imported_across_modules():
    assert private_imports() == []


@pytest.mark.parametrize(
    ("folder", "planted", "expected"),
    [
        ("core", "from ..sparse.observed import NOMINAL_STATE\n", "core/ imports costa.discover.sparse.observed"),
        ("full_state", "from ..sparse import search\n", "full_state/ imports costa.discover.sparse (sparse)"),
        ("sparse", "import costa.discover.full_state.weak_form\n", "sparse/ imports costa.discover.full_state"),
        ("sparse", "from .. import pipeline\n", "sparse/ imports costa.discover (the top level)"),
        (
            "core",
            "from ...discover.full_state.search import FullStateRound\n",
            "core/ imports costa.discover.full_state",
        ),
        (
            "sparse/filter",
            "from ..shooting.fit import shooting_fit\n",
            "sparse/filter/ imports costa.discover.sparse.shooting",
        ),
        ("sparse/shooting", "from ..filter import search\n", "sparse/shooting/ imports costa.discover.sparse.filter"),
        (
            "sparse",
            "from .pipeline import observations\n",
            "sparse/ imports costa.discover.sparse.pipeline (sparse/glue)",
        ),
    ],
)
def test_a_planted_import_is_caught(tmp_path, folder, planted, expected):
    """The check itself: one import across the layout, in a package of one module, is found."""
    (tmp_path / "costa" / "discover" / folder).mkdir(parents=True)
    (tmp_path / "costa" / "discover" / folder / "planted.py").write_text(planted)
    violations = layout_violations(tmp_path)
    assert len(violations) == 1 and expected in violations[0], violations


def test_a_planted_private_import_is_caught(tmp_path):
    (tmp_path / "costa" / "peers").mkdir(parents=True)
    (tmp_path / "costa" / "peers" / "planted.py").write_text("from ..discover.core.regression import _hidden\n")
    assert private_imports(tmp_path) == [
        "costa/peers/planted.py:1: imports _hidden from costa.discover.core.regression"
    ]
