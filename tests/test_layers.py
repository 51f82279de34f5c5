"""The package's imports point one way (CONTRIBUTING.md, "Layers"):

    core <- io <- staggered / wand / timewarp <- session <- widgets <- notebooks

read from the source with ``ast`` (every ``import`` and ``from ... import``, also the late ones inside functions),
so a new import that points the wrong way fails here with the file and line that wrote it.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "stagger_nb"
TECHNIQUES = {"staggered", "wand", "timewarp"}
# what each top-level part of the package may import from the package; anything else is a layering error
ALLOWED = {
    "core": set(),
    "io": {"core"},
    "plotting": {"core"},
    "scene3d": {"core"},
    "data": {"core", "io"},
    "staggered": {"core", "io"},
    "wand": {"core", "io"},
    "timewarp": {"core", "io"},
    "quality": {"core", "io", "staggered"},
    "session": {"core", "io", "data", "quality"} | TECHNIQUES,
    "batch": {"core", "io", "data", "quality", "session"} | TECHNIQUES,
    # the views show what the session and its models computed: no technique package, no maths of their own
    "widgets": {"core", "io", "data", "plotting", "scene3d", "session"},
    # `python -m stagger_nb.app NB`: starts Voila on a notebook (the notebooks' layer); imports no part of the package
    "app": set(),
}
UI_LIBRARIES = {"ipywidgets", "pythreejs", "anywidget"}   # only widgets/ draws


def _part(path: Path) -> str:
    return path.relative_to(PKG).with_suffix("").parts[0]   # "staggered", "scene3d", or "app" for app.py


def _imports(path: Path, root: Path = PKG):
    """(line, top-level part of stagger_nb or None, first name of a third-party module or None) per import."""
    module = list(path.relative_to(root.parent).with_suffix("").parts)
    package = module if path.name == "__init__.py" else module[:-1]
    if path.name == "__init__.py":
        package = package[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                full = base + (node.module.split(".") if node.module else [])
            else:
                full = node.module.split(".")
            if full[0] == "stagger_nb":
                if len(full) > 1:
                    yield node.lineno, full[1], None
                else:
                    for alias in node.names:
                        yield node.lineno, alias.name, None
            else:
                yield node.lineno, None, full[0]
        elif isinstance(node, ast.Import):
            for alias in node.names:
                full = alias.name.split(".")
                if full[0] == "stagger_nb":
                    yield node.lineno, full[1] if len(full) > 1 else None, None
                else:
                    yield node.lineno, None, full[0]


SOURCES = sorted(p for p in PKG.rglob("*.py") if _part(p) in ALLOWED)


def test_every_part_of_the_package_has_a_layer():
    parts = {_part(p) for p in PKG.rglob("*.py")} - {"__init__", "__main__"}
    assert parts <= set(ALLOWED), f"give {sorted(parts - set(ALLOWED))} a layer in ALLOWED (and CONTRIBUTING.md)"
    assert SOURCES, PKG


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(PKG)))
def test_imports_point_one_way(path):
    part = _part(path)
    wrong = [f"{path.relative_to(PKG.parent)}:{line}: {part} imports stagger_nb.{target}"
             for line, target, _ in _imports(path) if target and target != part and target not in ALLOWED[part]]
    ui = [f"{path.relative_to(PKG.parent)}:{line}: {part} imports {lib} (only widgets/ draws)"
          for line, _, lib in _imports(path) if lib in UI_LIBRARIES and part != "widgets"]
    assert not wrong + ui, "\n".join(wrong + ui)


def test_the_checker_sees_a_wrong_way_import(tmp_path):
    # the parser above resolves relative imports, late imports and `from stagger_nb import x` alike
    probe = tmp_path / "stagger_nb" / "core" / "x.py"
    probe.parent.mkdir(parents=True)
    probe.write_text("def f():\n    from ..widgets import SkeletonView\n    from stagger_nb import session\n"
                     "import ipywidgets\nfrom .rotations import quat_mul\n", encoding="utf-8")
    found = list(_imports(probe, tmp_path / "stagger_nb"))
    assert sorted(found, key=lambda r: r[0]) == [(2, "widgets", None), (3, "session", None),
                                                 (4, None, "ipywidgets"), (5, "core", None)]
