"""LAMMPS input templates (lammps_inputs/*.in), filled with string.Template ($name, $$ = $)."""

from __future__ import annotations

from pathlib import Path
from string import Template


def template_dir() -> Path:
    here = Path(__file__).resolve().parent
    for cand in (here / "_lammps_inputs", here.parent / "lammps_inputs"):
        if cand.is_dir():
            return cand
    raise FileNotFoundError(f"lammps_inputs/ not found next to {here}")


def render(name: str, **values: object) -> str:
    """Fill template `name`; a missing value is an error, never an empty string."""
    text = (template_dir() / name).read_text()
    return Template(text).substitute({k: str(v) for k, v in values.items()})
