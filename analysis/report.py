"""One-page reports of a run or a set of runs: Markdown (figures linked) and HTML (figures
embedded, so the page travels as one file).

A report is a list of blocks built by the analysis of a scenario; this module only lays them
out. Numbers are shown with 4 significant digits; the tables next to the report keep full
precision.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from runfiles.atomic import atomic_write_text
from runfiles.layout import display_dir


@dataclass
class Report:
    """Title, a line under it (what made the results), and blocks in page order."""

    title: str
    subtitle: str = ""
    blocks: list[tuple] = field(default_factory=list)

    def heading(self, text: str) -> None:
        self.blocks.append(("heading", text))

    def text(self, text: str) -> None:
        self.blocks.append(("text", text))

    def lead(self, text: str) -> None:
        """A paragraph right under the title, before every other block (what a reader must
        know first, such as a run cut short)."""
        self.blocks.insert(0, ("text", text))

    def values(self, values: dict[str, Any], caption: str = "") -> None:
        """A two-column table of named figures."""
        self.blocks.append(("table", pd.DataFrame({"quantity": list(values), "value": list(values.values())}), caption))

    def table(self, df: pd.DataFrame, caption: str = "", max_rows: int = 30) -> None:
        """A table (the first max_rows rows; the caption says how many there are)."""
        if len(df) > max_rows:
            caption = f"{caption} (first {max_rows} of {len(df)} rows)".strip()
            df = df.head(max_rows)
        self.blocks.append(("table", df, caption))

    def figure(self, path: Path, caption: str = "") -> None:
        """A PNG figure; left out of the page when the file does not exist (plots off)."""
        self.blocks.append(("figure", Path(path), caption))


#: What a table shows where there is no value: NaN, or None (a flag not raised, a fit not made).
NO_VALUE = "–"


def fmt(v: Any) -> str:
    """4 significant digits for floats, NO_VALUE for NaN and None, plain text otherwise."""
    if v is None:
        return NO_VALUE
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, (float, np.floating)):
        return NO_VALUE if math.isnan(v) else f"{v:.4g}"
    return str(v)


def to_markdown(rep: Report, directory: Path) -> str:
    out = [f"# {rep.title}", ""]
    if rep.subtitle:
        out += [rep.subtitle, ""]
    for block in rep.blocks:
        kind = block[0]
        if kind == "heading":
            out += [f"## {block[1]}", ""]
        elif kind == "text":
            out += [block[1], ""]
        elif kind == "table":
            df, caption = block[1], block[2]
            if caption:
                out += [f"*{caption}*", ""]
            out += [_md_table(df), ""]
        elif kind == "figure":
            path, caption = block[1], block[2]
            if path.exists():
                out += [f"![{caption}]({os.path.relpath(path, directory)})", ""]
                if caption:
                    out += [f"*{caption}*", ""]
    return "\n".join(out)


def to_html(rep: Report) -> str:
    parts = ["<!DOCTYPE html>", "<html><head><meta charset='utf-8'>", f"<title>{html.escape(rep.title)}</title>",
             "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;color:#111}"
             "table{border-collapse:collapse;margin:0.5em 0;font-size:0.85em}"
             "td,th{border:1px solid #999;padding:2px 6px;text-align:right}th{background:#eee}"
             "figure{margin:1em 0}img{max-width:100%}figcaption,caption{font-style:italic;font-size:0.9em}"
             "</style></head><body>", f"<h1>{html.escape(rep.title)}</h1>"]
    if rep.subtitle:
        parts.append(f"<p>{html.escape(rep.subtitle)}</p>")
    for block in rep.blocks:
        kind = block[0]
        if kind == "heading":
            parts.append(f"<h2>{html.escape(block[1])}</h2>")
        elif kind == "text":
            parts.append(f"<p>{html.escape(block[1])}</p>")
        elif kind == "table":
            df, caption = block[1], block[2]
            cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
            head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
            rows = "".join("<tr>" + "".join(f"<td>{html.escape(fmt(v))}</td>" for v in row) + "</tr>"
                           for row in df.itertuples(index=False))
            parts.append(f"<table>{cap}<tr>{head}</tr>{rows}</table>")
        elif kind == "figure":
            path, caption = block[1], block[2]
            if path.exists():
                data = base64.b64encode(path.read_bytes()).decode("ascii")
                parts.append(f"<figure><img alt='{html.escape(caption)}' src='data:image/png;base64,{data}'>"
                             f"<figcaption>{html.escape(caption)}</figcaption></figure>")
    parts.append("</body></html>")
    return "\n".join(parts)


def clear_report(directory: Path, stem: str = "report") -> None:
    """Remove an earlier report before its tables are rewritten: the report is written last,
    so a directory without one holds an analysis that did not finish."""
    for suffix in (".md", ".html"):
        (Path(directory) / f"{stem}{suffix}").unlink(missing_ok=True)


def write_report(rep: Report, directory: Path, stem: str = "report") -> tuple[Path, Path]:
    """Write `<directory>/<stem>.md` and `<stem>.html` atomically; returns both paths."""
    directory = Path(directory)
    md, page = directory / f"{stem}.md", directory / f"{stem}.html"
    atomic_write_text(md, to_markdown(rep, directory))
    atomic_write_text(page, to_html(rep))
    return md, page


def provenance_line(run_dir: Path) -> str:
    """What made a run, in one line (from its provenance.json)."""
    prov_path = Path(run_dir) / "provenance.json"
    if not prov_path.exists():
        return str(display_dir(run_dir))
    p = json.loads(prov_path.read_text())
    return (f"{display_dir(run_dir)} — brittle-driver {p.get('package_version', '?')} ({p.get('git_commit', '?')}), "
            f"LAMMPS {p.get('lammps_version', '?')}, plugin build {p.get('plugin_build_hash', '?')}, "
            f"seed {p.get('seed', '?')}, {p.get('mpi_ranks', '?')} rank(s), started {p.get('started', '?')}")


def _md_table(df: pd.DataFrame) -> str:
    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in df.itertuples(index=False):
        lines.append("| " + " | ".join(fmt(v).replace("|", "\\|") for v in row) + " |")
    return "\n".join(lines)
