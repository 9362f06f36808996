"""Our dumps open in OVITO with their columns mapped by name (optional: skipped when the `ovito`
package is not installed; `pip install ovito`).

BPM: at every snapshot of the BPM example, OVITO's bond-based cluster count equals the tool's
grain count (results/frames.parquet); the 2D run's dumps have no z column, which OVITO takes as
a 2D cell, and every particle has its radius. BCM: at the end of the quick impact, OVITO's
clusters over the intact interfaces (selected by the dump's `state` column) equal the tool's
fragment count, and the cells carry their orientation. OVITO's Python API needs the column
mapping of a `dump local` file spelled out (its GUI proposes one from the names); the atom
dumps need none.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

ovito = pytest.importorskip("ovito")
from ovito.io import import_file  # noqa: E402
from ovito.modifiers import (ClusterAnalysisModifier, DeleteSelectedModifier,  # noqa: E402
                             ExpressionSelectionModifier, LoadTrajectoryModifier)

from driver.config import parse_config  # noqa: E402
from driver.pipeline import execute  # noqa: E402

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run_example(name: str, out: Path) -> Path:
    data = yaml.safe_load((EXAMPLES / name).read_text())
    data["output"] = {**data.get("output", {}), "dir": str(out), "plots": False}
    execute(parse_config(data, name), show_progress=False)
    return out


def clusters(atoms: Path, bonds: Path, columns: list[str], drop: str | None = None):
    """(OVITO's cluster count over the bonds of `bonds`, the particle data) for the atoms dump
    `atoms`; drop: an expression on the bonds' columns selecting bonds deleted first."""
    pipeline = import_file(str(atoms))
    load = LoadTrajectoryModifier()
    load.source.load(str(bonds), columns=columns)
    pipeline.modifiers.append(load)
    if drop is not None:
        pipeline.modifiers.append(ExpressionSelectionModifier(operate_on="bonds", expression=drop))
        pipeline.modifiers.append(DeleteSelectedModifier(operate_on={"bonds"}))
    pipeline.modifiers.append(ClusterAnalysisModifier(neighbor_mode=ClusterAnalysisModifier.NeighborMode.Bonding))
    data = pipeline.compute()
    return data.attributes["ClusterAnalysis.cluster_count"], data


@pytest.mark.slow
def test_bpm_grains_equal_ovito_bond_clusters_at_every_snapshot(tmp_path, plugin_path):
    run = run_example("bpm_shear_2d.yaml", tmp_path / "bpm")
    frames = pd.read_parquet(run / "results" / "frames.parquet").set_index("step")
    snaps = json.loads((run / "snapshots.json").read_text())
    assert len(snaps) >= 4
    for snap in snaps:
        count, data = clusters(run / snap["atoms"], run / snap["bonds"],
                               ["Particle Identifiers.1", "Particle Identifiers.2", "Bond Type"])
        assert count == frames.loc[snap["step"], "n_grains"], snap
        assert data.cell.is2D and "Radius" in data.particles and np.min(data.particles["Radius"]) > 0


@pytest.mark.slow
def test_bcm_fragments_equal_ovito_clusters_of_intact_interfaces(tmp_path, plugin_path):
    run = run_example("bcm_impact_quick.yaml", tmp_path / "bcm")
    summary = json.loads((run / "results" / "summary.json").read_text())
    count, data = clusters(run / "dumps" / "cells.end.lammpstrj", run / "dumps" / "interfaces.end.lammpstrj",
                           ["Particle Identifiers.1", "Particle Identifiers.2", "state", "area", "energy",
                            "break_step", "break_time", "energy_at_break"], drop="state < 0.5")
    assert summary["n_fragments"] > 1
    assert count == summary["n_fragments"]
    assert "Orientation" in data.particles and "Radius" in data.particles and not data.cell.is2D
