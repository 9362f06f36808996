"""A short animation of the fragmentation (GIF) from a run's periodic dumps.

Each frame is rendered offscreen by analysis.pictures (atoms or cells coloured by their grain
at that frame) and the frames are joined with Pillow (a matplotlib dependency). Frames of a
deforming box differ in size: each is centred on a white canvas of the largest size.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np
from PIL import Image

from analysis.dumps import bond_pairs, read_atom_dump, read_local_dump
from analysis.grains import grains_from_bond_dump
from analysis.pictures import render_cells, render_particles_2d, render_particles_3d
from runfiles.atomic import atomic_save


def periodic_steps(dumps: Path, prefix: str) -> list[int]:
    """Timesteps of `<prefix>.<step>.lammpstrj` files, ascending."""
    steps = []
    for p in dumps.glob(f"{prefix}.*.lammpstrj"):
        mid = p.name[len(prefix) + 1:-len(".lammpstrj")]
        if mid.isdigit():
            steps.append(int(mid))
    return sorted(steps)


def animate_run(run_dir: Path, cfg: dict, prefix: str, draw: Callable[[Path, dict, int, Path], None],
                max_frames: int = 60, frame_ms: int = 150) -> Path | None:
    """Write plots/fragmentation.gif from the periodic dumps `<prefix>.<step>.lammpstrj` of a
    run directory (at most max_frames, evenly picked), each frame drawn by draw(run_dir, cfg,
    step, png) (particles_frame, cells_frame); None when the run has fewer than two periodic
    dumps."""
    run_dir = Path(run_dir)
    dumps = run_dir / "dumps"
    steps = periodic_steps(dumps, prefix)
    if len(steps) < 2:
        return None
    pick = np.unique(np.linspace(0, len(steps) - 1, min(max_frames, len(steps))).round().astype(int))
    steps = [steps[i] for i in pick]
    with tempfile.TemporaryDirectory() as tmp:
        pngs = []
        for k, step in enumerate(steps):
            png = Path(tmp) / f"{k:04d}.png"
            draw(run_dir, cfg, step, png)
            pngs.append(png)
        out = run_dir / "plots" / "fragmentation.gif"
        write_gif(pngs, out, frame_ms)
    return out


def write_gif(pngs: list[Path], out: Path, frame_ms: int = 150) -> None:
    """Join PNG frames into a looping GIF, each centred on a canvas of the largest frame size."""
    images = [Image.open(p).convert("RGB") for p in pngs]
    w = max(im.width for im in images)
    h = max(im.height for im in images)
    frames = []
    for im in images:
        canvas = Image.new("RGB", (w, h), "white")
        canvas.paste(im, ((w - im.width) // 2, (h - im.height) // 2))
        frames.append(canvas)
    atomic_save(out, lambda p: frames[0].save(p, format="GIF", save_all=True, append_images=frames[1:],
                                              duration=frame_ms, loop=0))


def particles_frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    atoms = read_atom_dump(run_dir / "dumps" / f"atoms.{step}.lammpstrj")[-1]
    bonds = read_local_dump(run_dir / "dumps" / f"bonds.{step}.lammpstrj")[-1]
    pairs, types = bond_pairs(bonds)
    labels = grains_from_bond_dump(len(atoms.ids), pairs, types)
    dim = int(cfg["model"]["dimension"])
    title = f"{cfg['name']}: step {step}, {labels.max() + 1} grains"
    if dim == 2:
        system = json.loads((run_dir / "system.json").read_text())
        diam = {int(k): v for k, v in system["type_diameters"].items()}
        radii = 0.5 * np.array([diam[int(t)] for t in atoms.types])
        render_particles_2d(atoms.positions, radii, labels, atoms.box, png, title)
    else:
        render_particles_3d(atoms.positions, labels, png, title)


def cells_frame(run_dir: Path, cfg: dict, step: int, png: Path) -> None:
    from analysis.bcm_impact import cell_shapes, fragments_of, read_interfaces  # noqa: PLC0415
    from analysis.fragment_shapes import vertices_in_space  # noqa: PLC0415

    cells = read_atom_dump(run_dir / "dumps" / f"cells.{step}.lammpstrj")[-1]
    ifaces = read_interfaces(run_dir / "dumps" / f"interfaces.{step}.lammpstrj")
    labels = fragments_of(len(cells.ids), ifaces)
    body, faces, _ = cell_shapes(run_dir)
    offsets = np.concatenate([[0], np.cumsum([len(v) for v in body])])
    space = vertices_in_space(np.concatenate(body), offsets, cells.positions, cells.quaternions())
    verts = [space[offsets[i]:offsets[i + 1]] for i in range(len(cells.ids))]
    render_cells(verts, faces, labels, png, f"{cfg['name']}: step {step}, {labels.max() + 1} fragments")
