"""Interface stiffness per area (model.interface_stiffness: per_area) and unbonded small faces
(model.min_interface_area).

per_area: an interface's k_n and k_t are the configured values times S / <S>; two interfaces
of areas S and 4 S (so <S> = 2.5 S) under the same opening carry forces 0.4 k_n delta and
1.6 k_n delta, in the ratio 1 : 4, and break at the same opening delta_c = sqrt(4 <S> G_c / k_n)
(stored convention: k_n S/<S> delta^2 / 2 = 2 S G_c); per_interface they break at openings in
the ratio 1 : 2.
"""

from __future__ import annotations

import numpy as np
import pytest

from test_bcm_interface import A, KN, S, T1, T2, N, X1, by_tag, geometry_line, make_cells, set_by_tag

GC = 1.0
OFFSET = 10 * A * T1  # the second pair, far from the first
CENTRES = [X1, X1 + A * N, X1 + OFFSET, X1 + OFFSET + A * N]


def face(centre: np.ndarray, side: float) -> np.ndarray:
    return np.array([centre + 0.5 * side * (u * T1 + v * T2) for u, v in [(-1, -1), (1, -1), (1, 1), (-1, 1)]])


def two_pairs(lmp, tmp_path, stiffness: str) -> None:
    geometry = "\n".join([
        "# tag1 tag2 area nx ny nz npts points",
        geometry_line(1, 2, S, N, face(X1 + 0.5 * A * N, A)),
        # the same square of points, declared 4 S: the law reads the area from the table
        geometry_line(3, 4, 4 * S, N, face(X1 + OFFSET + 0.5 * A * N, A)),
    ]) + "\n"
    make_cells(lmp, tmp_path, CENTRES, [(1, 2, None), (3, 4, None)], geometry=geometry, gc=GC,
               energy=f"stored stiffness {stiffness}")
    lmp.command("compute bst all bond/local b1")
    lmp.command("run 0")  # the reference state: cells as placed


def open_both(lmp, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Cells 2 and 4 pulled away from 1 and 3 by `delta` along the normal; run 0; (forces on
    cells 2 and 4, intact flags)."""
    set_by_tag(lmp, "x", [CENTRES[0], CENTRES[1] + delta * N, CENTRES[2], CENTRES[3] + delta * N])
    set_by_tag(lmp, "v", np.zeros((4, 3)))
    lmp.command("run 0")
    f = by_tag(lmp, "f")
    first = np.asarray(lmp.numpy.extract_compute("pl", 2, 2))[:, 0]
    state = np.asarray(lmp.numpy.extract_compute("bst", 2, 1)).ravel()
    # one row per interface, ordered by its first cell (1: the small face, 3: the large one)
    return f[[1, 3]], np.array([state[first == 1][0], state[first == 3][0]])


def test_per_area_forces_scale_with_area(lmp, tmp_path):
    two_pairs(lmp, tmp_path, "per_area")
    delta = 1e-9
    f, _ = open_both(lmp, delta)
    mean = 2.5 * S
    np.testing.assert_allclose(f[0], -KN * (S / mean) * delta * N, rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(f[1], -KN * (4 * S / mean) * delta * N, rtol=1e-8, atol=1e-15)
    assert np.linalg.norm(f[1]) / np.linalg.norm(f[0]) == pytest.approx(4.0, rel=1e-8)


@pytest.mark.parametrize("stiffness", ["per_area", "per_interface"])
def test_griffith_openings(lmp, plugin_path, tmp_path, stiffness):
    """per_area: both interfaces break at delta_c = sqrt(4 <S> G_c / k_n); per_interface at
    sqrt(4 S G_c / k_n) and sqrt(16 S G_c / k_n)."""
    from driver.engine import Lammps

    mean = 2.5 * S
    if stiffness == "per_area":
        critical = [np.sqrt(4 * mean * GC / KN)] * 2
    else:
        critical = [np.sqrt(4 * S * GC / KN), np.sqrt(4 * 4 * S * GC / KN)]
    for which, dc in enumerate(critical):
        for factor, intact in ((0.999, True), (1.001, False)):
            inst = Lammps()
            try:
                inst.command(f"plugin load {plugin_path}")
                two_pairs(inst, tmp_path, stiffness)
                _, state = open_both(inst, factor * dc)
                # bond/local b1 (the state) per interface: 1 intact, 0 broken; interface `which`
                assert (state[which] > 0.5) == intact, (stiffness, which, factor)
            finally:
                inst.close()


def test_min_interface_area_leaves_small_faces_unbonded(tmp_path, plugin_path):
    """Faces below min_interface_area x the median face area are not glued: not in the
    interface table nor the data file's bonds; A_0 and D_w count bonded interfaces only."""
    import json

    from driver.bcm.particle import particle_tessellation
    from driver.bcm.section import BCMModel
    from driver.config import parse_config
    from driver.pipeline import execute
    from driver.cache import cache_base

    frac = 0.05
    tess = particle_tessellation(BCMModel(n_cells=100), 3, cache_base() / "tessellations")
    cut = frac * np.median(tess.iface_area)
    assert (tess.iface_area < cut).sum() > 0  # this tessellation has such faces
    out = tmp_path / "run"
    execute(parse_config({"name": "cut", "seed": 3,
                          "model": {"kind": "bcm", "n_cells": 100, "min_interface_area": frac},
                          "scenario": {"kind": "impact", "velocity": 3.0, "max_time": 2e-5},
                          "output": {"dir": str(out), "plots": False}}), show_progress=False)
    table = [line.split() for line in (out / "interfaces.txt").read_text().splitlines() if line[0] != "#"]
    areas = np.array([float(words[2]) for words in table])
    system = json.loads((out / "system.json").read_text())
    assert areas.min() >= cut and len(areas) == (tess.iface_area >= cut).sum() == system["n_interfaces"]
    assert system["n_faces_unbonded"] == (tess.iface_area < cut).sum()
    assert system["A0"] == pytest.approx(areas.sum(), rel=1e-9)
    data = (out / "system.data").read_text()
    assert f"{len(areas)} bonds" in data
    summary = json.loads((out / "results/summary.json").read_text())
    assert summary["A0"] == pytest.approx(system["A0"], rel=1e-12)
    assert summary["D_w"] == pytest.approx(summary["A"] / system["A0"], rel=1e-12)


def test_a_particle_whose_erosion_merged_vertices_runs(tmp_path, plugin_path):
    """Seed 4 at 100 cells: one core face comes out of the erosion 1.1e-5 of its cell's size off
    its plane (vertices merged where a face nearly vanished); the cells file is accepted."""
    from driver.config import parse_config
    from driver.pipeline import execute

    out = tmp_path / "run"
    execute(parse_config({"name": "s4", "seed": 4, "model": {"kind": "bcm", "n_cells": 100},
                          "scenario": {"kind": "impact", "velocity": 3.0, "max_time": 1e-5},
                          "output": {"dir": str(out), "plots": False}}), show_progress=False)
    assert (out / "results/summary.json").exists()
