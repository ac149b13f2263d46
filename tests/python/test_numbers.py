"""The numbers of README.md and docs/results/*.md that come from the committed rows are the rows' numbers:
docs/results/make_tables.py --check reproduces every marked block and tables.md unchanged, and a block
edited by hand is caught (on a copy)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results"
SCRIPT = RESULTS / "make_tables.py"

pytest.importorskip("pandas")


def check(root: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), "--check", "--root", str(root)],
                          capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def make_tables():
    sys.path.insert(0, str(RESULTS))
    try:
        import make_tables

        yield make_tables
    finally:
        sys.path.remove(str(RESULTS))


@pytest.fixture(scope="module")
def values(make_tables):
    return make_tables.all_values()


def copy_pages(target: Path) -> Path:
    """README.md and docs/results/*.md under ``target``, as the repository holds them."""
    (target / "docs" / "results").mkdir(parents=True)
    shutil.copy(ROOT / "README.md", target / "README.md")
    for page in RESULTS.glob("*.md"):
        shutil.copy(page, target / "docs" / "results" / page.name)
    return target


def test_the_committed_text_is_what_the_rows_give():
    result = check(ROOT)
    assert result.returncode == 0, f"run docs/results/make_tables.py:\n{result.stderr}"


def test_every_page_with_numbers_from_the_rows_has_marked_blocks(make_tables):
    pages = {path.relative_to(ROOT).as_posix(): path.read_text() for path in make_tables.marked_pages(ROOT)}
    for name in ("README.md", "docs/results/README.md", "docs/results/closed_loop.md", "docs/results/execution.md"):
        assert make_tables.BLOCK.search(pages[name]), f"{name} has no generated block"


def test_a_block_edited_by_hand_is_named(tmp_path, make_tables):
    root = copy_pages(tmp_path)
    page = root / "docs" / "results" / "README.md"
    text = page.read_text()
    match = next(match for match in make_tables.BLOCK.finditer(text) if match["name"] == "fig10-default-full")
    page.write_text(text[:match.start("body")] + "the slowest in 0.32 s" + text[match.end("body"):])  # a typed number
    result = check(root)
    assert result.returncode == 1
    assert "docs/results/README.md: block fig10-default-full" in result.stderr
    assert result.stderr.count("would change") == 1  # nothing else differs
    assert page.read_text() != text  # --check wrote nothing: the hand edit is still there
    subprocess.run([sys.executable, str(SCRIPT), "--root", str(root)], check=True, capture_output=True, timeout=120)
    assert page.read_text() == text  # and the rewrite puts the rows' value back


def test_an_edited_table_file_is_named(tmp_path):
    root = copy_pages(tmp_path)
    tables = root / "docs" / "results" / "tables.md"
    text = tables.read_text()
    assert " s (" in text
    tables.write_text(text.replace(" s (", " s ((", 1))  # any hand edit of a generated number
    result = check(root)
    assert result.returncode == 1 and "docs/results/tables.md" in result.stderr


def test_blocks_are_filled_inline_and_as_lines(make_tables):
    values = {"one": "1.5 s", "table": "| a |\n|---|\n| 2 |"}
    text = "took <!-- generated: one -->9 s<!-- /generated --> in all\n\n<!-- generated: table -->\nold\n<!-- /generated -->\n"
    new, changed = make_tables.fill_blocks(text, values, "page.md")
    assert new == ("took <!-- generated: one -->1.5 s<!-- /generated --> in all\n\n"
                   "<!-- generated: table -->\n| a |\n|---|\n| 2 |\n<!-- /generated -->\n")
    assert changed == ["one", "table"]
    assert make_tables.fill_blocks(new, values, "page.md") == (new, [])


@pytest.mark.parametrize("text, problem", [
    ("a <!-- generated: nothing -->1<!-- /generated -->", "no value named 'nothing'"),
    ("a <!-- generated: one -->1 and on", "without its"),
    ("<!-- generated: one -->1<!-- /generated --> at the start of a line", "starts a line"),
    ("a <!-- generated: one -->1 <!-- generated: one -->2<!-- /generated -->", "not closed"),
])
def test_bad_markers_are_refused(make_tables, text, problem):
    with pytest.raises(make_tables.BlockError, match=problem):
        make_tables.fill_blocks(text, {"one": "1"}, "page.md")


def test_the_stale_numbers_are_gone_and_the_rows_say_so(values):
    # The slowest full-scale Fig. 10 run (was typed 0.32 s), recomputed here from the rows.
    import pandas as pd

    rows = pd.read_parquet(ROOT / "docs" / "results" / "fig10.parquet")
    slowest = rows[(rows["scale"] == 1.0) & rows["solved"]]["planning_time_s"].max()
    assert f"the slowest in {slowest:.3f} s" in values["fig10-default-full"] and "0.32 s" not in values["fig10-default-full"]
    assert "not reproduced" in values["fig12-paper-verdict"]  # N* = 1000 is faster than 100 in these rows
