"""The documentation (issue 26, point 3): the README is one screen that names every command; the
Markdown tables are unbroken; every schema field has a description; and the site builds in
strict mode with every field, command, option, record field and dump column on its generated
page. The site tests are skipped when MkDocs (the `docs` extra) is not installed."""

from __future__ import annotations

import html
import importlib.util
import os
import re
import subprocess
import sys
import time
import typing
from pathlib import Path

import pytest
from pydantic import BaseModel

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"

#: The README's first two commands, a project rule: byte for byte.
FIRST_COMMANDS = [
    "python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/driver run examples/bpm_shear_2d.yaml",
    'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/pytest -q',
]
#: "At most about 150 lines".
README_MAX_LINES = 150


def _hooks():
    """docs/hooks.py, whose SOURCES say where each generated page comes from."""
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HOOKS = _hooks()


def _source(name: str):
    return HOOKS._load(HOOKS.SOURCES[name])


def _commands() -> dict:
    import typer.main  # noqa: PLC0415

    return dict(typer.main.get_command(_source("cli")).commands)


def _models_in(annotation) -> list[type]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def _fields(cls: type, prefix: str = ""):
    """(dotted key, field) of every field of a schema, sections of every kind included; the keys
    of a mapping of sections (`dict[str, Section]`) are written `<name>`."""
    for name, field in cls.model_fields.items():
        key = f"{prefix}.{name}" if prefix else name
        yield key, field
        mapping = "dict[" in str(field.annotation)
        for sub in _models_in(field.annotation):
            yield from _fields(sub, f"{key}.<name>" if mapping else key)


SCHEMAS = {"run config": "reference/config", "material file": "reference/material",
           "compare file": "reference/compare"}


# ------------------------------------------------------------------------------ the README
def _readme_lines() -> list[str]:
    return README.read_text().splitlines()


def test_readme_keeps_its_first_two_commands():
    lines = _readme_lines()
    block = lines[lines.index("```bash") + 1:]
    assert block[:2] == FIRST_COMMANDS
    assert lines.index("```bash") < 5, "the two commands open the README"


def test_readme_is_one_screen():
    assert len(_readme_lines()) <= README_MAX_LINES


def _table_after(lines: list[str], heading: str) -> list[str]:
    start = lines.index(heading)
    first = next(k for k in range(start + 1, len(lines)) if lines[k].startswith("|"))
    rows = []
    for line in lines[first:]:
        if not line.startswith("|"):
            break
        rows.append(line)
    return rows


def test_readme_command_table_has_every_command():
    rows = _table_after(_readme_lines(), "## Commands")
    assert re.fullmatch(r"\|(-+\|)+", rows[1].replace(" ", "")), "a header, then the delimiter row"
    listed = {m for row in rows[2:] for m in re.findall(r"`driver ([a-z]+)", row.split(" | ")[0])}
    assert set(_commands()) <= listed, f"missing from the README's command table: {set(_commands()) - listed}"


def test_readme_links_point_to_files():
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README.read_text()):
        if "://" not in target:
            assert (ROOT / target).exists(), target


# ------------------------------------------------------------------------------ Markdown
def _markdown_files() -> list[Path]:
    return [README, *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "plugins" / "doc").glob("*.md"))]


def broken_tables(text: str) -> list[str]:
    """Problems of the Markdown tables of a text: a table cut by a blank line (the rows after it
    render as plain text), or table rows without a delimiter row under their header."""
    problems = []
    lines = text.splitlines()
    row = lambda line: line.startswith("|") and line.rstrip().endswith("|")  # noqa: E731
    fenced = False
    k = 0
    while k < len(lines):
        if lines[k].lstrip().startswith("```"):
            fenced = not fenced
        if fenced or not row(lines[k]):
            k += 1
            continue
        start = k
        while k < len(lines) and row(lines[k]):
            k += 1
        if start + 1 >= k or not re.fullmatch(r"\|(\s*:?-+:?\s*\|)+", lines[start + 1].strip()):
            problems.append(f"line {start + 1}: table rows without a header and delimiter row")
        gap = k
        while gap < len(lines) and not lines[gap].strip():
            gap += 1
        if gap > k and gap < len(lines) and row(lines[gap]) and not re.fullmatch(
                r"\|(\s*:?-+:?\s*\|)+", lines[gap + 1].strip() if gap + 1 < len(lines) else ""):
            problems.append(f"line {gap + 1}: a table continues after a blank line")
    return problems


def test_broken_tables_are_found():
    table = "| a | b |\n|---|---|\n| 1 | 2 |\n"
    assert broken_tables(table) == []
    assert broken_tables(table + "\n| 3 | 4 |\n")  # the README's former command table
    assert broken_tables("| 3 | 4 |\n| 5 | 6 |\n")
    assert broken_tables(table + "\n" + table) == []  # two tables
    assert broken_tables("```\n| not | a table |\n```\n") == []


@pytest.mark.parametrize("path", _markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_markdown_tables_are_unbroken(path):
    assert broken_tables(path.read_text()) == []


# ------------------------------------------------------------------------------ the schemas
@pytest.mark.parametrize("schema", list(SCHEMAS))
def test_every_schema_field_has_a_description(schema):
    missing = [key for key, field in _fields(_source(schema)) if not (field.description or "").strip()]
    assert missing == [], f"fields without description= (the reference's text): {missing}"


# ------------------------------------------------------------------------------ the site
@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once in strict mode (a broken link, anchor or page fails it)."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("material")
    out = tmp_path_factory.mktemp("site")
    t0 = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
                           "-d", str(out)], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"}, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    print(f"mkdocs build --strict: {time.monotonic() - t0:.1f} s")
    return out


def _page(site: Path, rel: str) -> str:
    return (site / rel / "index.html").read_text()


@pytest.mark.parametrize("schema", list(SCHEMAS))
def test_reference_page_lists_every_field(site, schema):
    page = _page(site, SCHEMAS[schema])
    missing = [key for key, _ in _fields(_source(schema)) if f"<code>{html.escape(key)}</code>" not in page]
    assert missing == []


def test_cli_reference_lists_every_command_and_option(site):
    page = _page(site, "reference/cli")
    for name, cmd in _commands().items():
        assert f'id="driver-{name}"' in page, name
        for param in cmd.params:
            for opt in [*param.opts, *param.secondary_opts]:
                if opt.startswith("-"):
                    assert opt in page, f"driver {name} {opt}"
            if param.param_type_name == "argument":
                assert param.name.upper() in page, f"driver {name} {param.name}"


def test_records_reference_lists_every_field_and_column(site):
    page = _page(site, "reference/records")
    records, dumps = HOOKS.records_of(_source("records"))
    assert records and dumps
    for _, record in records:
        assert all(f"<code>{f.name}</code>" in page for f in record.fields), record.name
    for _, dump in dumps:
        assert all(f"<code>{c.name}</code>" in page for c in dump.columns), dump.name


def test_every_plugin_page_is_in_the_site(site):
    docs = sorted((ROOT / HOOKS.SOURCES["plugin docs"]).glob("*.md"))
    assert docs
    index = _page(site, "plugins")
    for doc in docs:
        assert (site / "plugins" / doc.stem / "index.html").exists(), doc.name
        assert f'href="{doc.stem}/"' in index, doc.name


def test_site_tables_render(site):
    """Every Markdown table of a hand-written page is an HTML table of the built page."""
    for path in sorted((ROOT / "docs").rglob("*.md")):
        rel = path.relative_to(ROOT / "docs").with_suffix("")
        html = (site / rel.parent if rel.name == "index" else site / rel) / "index.html"
        source = path.read_text()
        expected = len(re.findall(r"^\|(\s*:?-+:?\s*\|)+\s*$", re.sub(r"```.*?```", "", source, flags=re.S),
                                  flags=re.M))
        assert html.read_text().count("<table>") == expected, path.name
