"""One-page reports: Markdown links the figures, HTML embeds them; tables and values appear."""

from __future__ import annotations

import base64

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from analysis.report import Report, fmt, write_report  # noqa: E402


def test_report_markdown_and_html(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([1, 2], [3, 4])
    png = tmp_path / "plots" / "a.png"
    png.parent.mkdir()
    fig.savefig(png)
    plt.close(fig)
    rep = Report("Title <x>", "made by a test")
    rep.values({"tau": 1.23456789, "n": 12, "missing": float("nan")}, "values")
    rep.table(pd.DataFrame({"a": range(50), "b": 0.5}), "long table", max_rows=10)
    rep.figure(png, "a figure")
    rep.figure(tmp_path / "plots" / "absent.png", "not drawn")
    md, page = write_report(rep, tmp_path)
    text = md.read_text()
    assert "| tau | 1.235 |" in text and "| missing | – |" in text
    assert "![a figure](plots/a.png)" in text and "absent.png" not in text
    assert "first 10 of 50 rows" in text and "| 9 | 0.5 |" in text and "| 10 | 0.5 |" not in text
    html = page.read_text()
    assert "Title &lt;x&gt;" in html
    assert base64.b64encode(png.read_bytes()).decode()[:200] in html  # embedded, not linked
    assert "absent" not in html


def test_fmt():
    assert fmt(3.14159265) == "3.142" and fmt(1.5e-7) == "1.5e-07" and fmt(True) == "True" and fmt(7) == "7"


def test_a_flag_not_raised_shows_no_value_not_none(tmp_path):
    """A summary's flag that is None (not raised: the shear's tau_final_flag, the impact's
    mass_tau when no fit is made) shows the table's no-value dash, in values and in tables,
    Markdown and HTML alike."""
    rep = Report("flags")
    rep.values({"tau_final": 1.706, "tau_final_flag": None, "rule": "the last 20%"}, "summary")
    rep.table(pd.DataFrame({"step": [0, 100], "tau_flag": [None, "too few grains"]}), "frames")
    md, page = write_report(rep, tmp_path)
    text, html = md.read_text(), page.read_text()
    assert "| tau_final_flag | – |" in text and "| 0 | – |" in text and "| 100 | too few grains |" in text
    assert "<td>tau_final_flag</td><td>–</td>" in html and "<td>0</td><td>–</td>" in html
    assert "None" not in text and "None" not in html
    assert fmt(None) == "–"
