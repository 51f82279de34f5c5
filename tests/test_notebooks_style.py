"""The tutorials read as tutorials (issue 14): figure cells are a few lines because figures come from
stagger_nb.plotting; no notebook builds plotly objects by hand; the first code cell (set-up) may be longer."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("[0-9]*.py"))
MAX_LINES = 12


def code_cells(path: Path) -> list[list[str]]:
    """Code cells of a jupytext percent file, as lists of their non-blank lines."""
    cells, current = [], None
    for line in path.read_text().splitlines():
        if line.startswith("# %%"):
            current = None if "[markdown]" in line else []
            if current is not None:
                cells.append(current)
        elif current is not None and line.strip():
            current.append(line)
    return cells


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_code_cells_are_short_outside_the_set_up_cell(path):
    cells = code_cells(path)
    assert cells, f"{path.name}: no code cells"
    long = [(i, len(c)) for i, c in enumerate(cells[1:], start=1) if len(c) > MAX_LINES]
    assert not long, f"{path.name}: code cells longer than {MAX_LINES} lines (cell index, lines): {long}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_no_plotly_objects_built_by_hand(path):
    text = path.read_text()
    assert not re.search(r"\bgo\.", text), f"{path.name}: builds plotly graph objects (go.) by hand"
    assert "graph_objects" not in text and "make_subplots" not in text


def test_the_style_check_sees_long_cells(tmp_path):
    p = tmp_path / "x.py"
    p.write_text("# %%\nimport a\n# %% [markdown]\n# text\n# %%\n" + "x = 1\n" * (MAX_LINES + 1))
    assert [len(c) for c in code_cells(p)] == [1, MAX_LINES + 1]
