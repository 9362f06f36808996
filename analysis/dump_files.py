"""`driver post FILE...`: grains from dump files named on the command line (no run directory,
e.g. dumps of a run made elsewhere).

Atom dumps (`dump custom` with id and x y z, optionally type, vx vy vz, mass, radius) and bond
dumps (`dump local` whose first three columns are atom1, atom2 and a type or state: > 0 intact,
<= 0 broken, as both models' dumps write them) are told apart by their headers and paired by
timestep. Every paired frame gives a grain table, N(M), moments and a row of the frame table;
consecutive frames give the parent-child tracking table. Grain masses M in N(M), the
moments and tau are particle counts (SPEC 2.5's unit: the particle mass); the grain table
also has each grain's mass from the dump's mass column (1 per atom without one).
"""

from __future__ import annotations

import gzip
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import pandas as pd

from analysis.dumps import DumpError, iter_atom_dump, iter_local_dump, read_atom_dump
from analysis.grain_table import frame_grains
from analysis.pictures import render_particles_2d, render_particles_3d
from analysis.plots import plot_nm
from analysis.report import Report, clear_report, write_report
from analysis.statistics import SMALL_GRAIN_CUT, fit_grain_tau, frame_measures, mass_distribution
from analysis.tables import save_table
from analysis.tracking import lineage_table


def dump_head(path: Path) -> tuple[str, int]:
    """('atoms' or 'bonds', first timestep) from the first frame's header (plain or gzip)."""
    with open(path, "rb") as fh:
        gz = fh.read(2) == b"\x1f\x8b"
    opener = gzip.open if gz else open
    step = None
    with opener(path, "rb") as fh:
        for _ in range(64):
            line = fh.readline()
            if not line:
                break
            if line.startswith(b"ITEM: TIMESTEP"):
                try:
                    step = int(fh.readline().split()[0])
                except (ValueError, IndexError):
                    break
            elif line.startswith(b"ITEM: ATOMS") and step is not None:
                return "atoms", step
            elif line.startswith(b"ITEM: ENTRIES") and step is not None:
                return "bonds", step
    raise DumpError(f"{path}: not a LAMMPS text dump (no 'ITEM: TIMESTEP' then 'ITEM: ATOMS' or 'ITEM: ENTRIES' "
                    "header in its first lines)")


def _stream(files: list[Path], kind: str, reader: str, problems: list[str]) -> Iterator[tuple]:
    """(frame, file) of the files in order, one frame in memory at a time; a truncated or
    inconsistent frame ends its file's stream (the error goes to `problems`, the frames
    before it are kept)."""
    for f in files:
        try:
            if kind == "bonds":
                frames = iter_local_dump(f)
            elif reader == "mdanalysis":  # reads the whole file: its complete frames come with the error
                try:
                    frames = iter(read_atom_dump(f, engine="mdanalysis"))
                except DumpError as exc:
                    yield from ((fr, f) for fr in exc.frames)
                    raise
            else:
                frames = iter_atom_dump(f)
            for fr in frames:
                yield fr, f
        except DumpError as exc:
            problems.append(str(exc))


def paired_frames(files: list[Path], reader: str = "numpy", problems: list[str] | None = None) -> Iterator[tuple]:
    """(atom frame, atom file, bond frame, bond file) for every timestep in both the atom and
    the bond dumps, in timestep order, streamed (files ordered by their first timestep)."""
    problems = [] if problems is None else problems
    heads = {Path(f): dump_head(Path(f)) for f in files}
    by_kind = {k: sorted((f for f in heads if heads[f][0] == k), key=lambda f: heads[f][1]) for k in ("atoms", "bonds")}
    if not by_kind["atoms"] or not by_kind["bonds"]:
        raise DumpError(f"need atom and bond dumps; got {len(by_kind['atoms'])} atom and {len(by_kind['bonds'])} "
                        f"bond files among {', '.join(map(str, files))}")
    streams = {k: _stream(v, k, reader, problems) for k, v in by_kind.items()}
    cur = {k: next(streams[k], None) for k in streams}
    last = {"atoms": None, "bonds": None}  # (timestep, file) of the frame each stream gave before

    def advance(k: str) -> None:
        frame, file = cur[k]
        last[k] = (frame.timestep, file)
        cur[k] = next(streams[k], None)
        if cur[k] is not None and cur[k][0].timestep <= last[k][0]:
            raise DumpError(f"{cur[k][1]}: timestep {cur[k][0].timestep} comes after timestep {last[k][0]} of "
                            f"{last[k][1]}: the {k} dumps are not in timestep order")

    while cur["atoms"] is not None and cur["bonds"] is not None:
        (fa, file_a), (fb, file_b) = cur["atoms"], cur["bonds"]
        if fa.timestep == fb.timestep:
            yield fa, file_a, fb, file_b
            advance("atoms")
            advance("bonds")
        else:
            advance("atoms" if fa.timestep < fb.timestep else "bonds")


def analyse_dump_files(files: list[Path], out: Path, dimension: int | None = None, plots: bool = True,
                       m_min: float | None = None, reader: str = "numpy", count_above: tuple[float, ...] = (10, 100),
                       log: Callable[[str], None] | None = None) -> dict:
    """Grain tables, N(M), frame table, tracking, plots and report of the paired frames of
    `files` into `out`. dimension: 2 or 3 (default: 2 when every z is equal); m_min: the
    small-grain cut of N(M) (default SPEC 2.5's for the dimension); count_above: further
    thresholds whose grain counts the frame table holds; reader: the atom-dump
    engine of analysis.dumps.read_atom_dump ("numpy", or "mdanalysis" for MDAnalysis'
    DumpReader positions and velocities); log: called with a line per frame (progress) and
    per problem. Frames are streamed: one atom and one bond frame in memory at a time. A
    truncated dump ends its file's frames with a warning; the frames before it are analysed."""
    files = [Path(f) for f in files]
    out = Path(out)
    log = log or (lambda _msg: None)
    problems: list[str] = []
    grain_rows, nm_rows, frame_rows, labels_seq, steps = [], [], [], [], []
    ids0 = dim = cut = thresholds = last = None
    for af, file_a, bf, file_b in paired_frames(files, reader, problems):
        if ids0 is None:
            ids0 = af.ids
            dim = dimension or (2 if af.positions.shape[1] == 2 or np.ptp(af.positions[:, 2]) == 0 else 3)
            cut = m_min if m_min is not None else SMALL_GRAIN_CUT[dim]
            thresholds = tuple(t for t in count_above if t != cut)
            clear_report(out)
        elif not np.array_equal(af.ids, ids0):
            raise DumpError(f"{file_a}: timestep {af.timestep} holds other atoms than timestep {steps[0]}: "
                            "tracking needs the same atoms in every frame")
        step = af.timestep
        labels, table = frame_grains(af, bf, dim)
        # M counts particles (SPEC 2.5: masses in units of the particle mass m), whatever the
        # dump's mass column holds (kg for BCM cells); the grain table keeps the mass too
        masses = table["size"].to_numpy(dtype=float)
        table.insert(0, "step", step)
        grain_rows.append(table)
        labels_seq.append(labels)
        steps.append(step)
        nm = mass_distribution(masses, m_min=cut)
        nm.insert(0, "step", step)
        nm_rows.append(nm)
        fit = fit_grain_tau(masses, cut, table["percolating"].to_numpy(), n_bootstrap=200)
        frame_rows.append({"step": step, "atoms_file": str(file_a), "bonds_file": str(file_b),
                           "n_atoms": len(af.ids), **frame_measures(masses, table["percolating"], cut, thresholds),
                           "largest_grain_mass": float(table["mass"].max()),
                           "tau": None if fit is None else fit.tau, "tau_sigma": None if fit is None else fit.sigma,
                           "tau_sigma_bootstrap": None if fit is None else fit.sigma_bootstrap})
        last = af
        log(f"step {step}: {len(af.ids)} atoms, {len(masses)} grains")
    for msg in problems:
        log(f"warning: {msg}")
    if not steps:
        raise DumpError("no timestep is in both the atom and the bond dumps"
                        + (f" ({'; '.join(problems)})" if problems else ""))
    grains = pd.concat(grain_rows, ignore_index=True)
    nm_all = pd.concat(nm_rows, ignore_index=True)
    frames = pd.DataFrame(frame_rows)
    tracking = lineage_table(labels_seq)
    tracking.insert(1, "step_child", tracking["frame"].map(dict(enumerate(steps))))

    save_table(grains, out / "grains")
    save_table(nm_all, out / "nm")
    save_table(frames, out / "frames")
    save_table(tracking, out / "tracking")
    title = f"{len(steps)} frame(s) of {len(ids0)} atoms, {dim}D"
    if plots:
        plot_nm(nm_all, out / "plots" / "nm.png", title, by="step", legend="step {:d}")
        radii = last.extra.get("radius", np.full(len(last.ids), 0.5))
        if dim == 2:
            render_particles_2d(last.positions, radii, labels_seq[-1], last.box, out / "plots" / "grains.png",
                                f"timestep {steps[-1]}")
        else:
            render_particles_3d(last.positions, labels_seq[-1], out / "plots" / "grains.png", f"timestep {steps[-1]}")
    rep = Report(f"Grains of dump files: {title}", "files: " + ", ".join(map(str, files)))
    for msg in problems:
        rep.text(f"Warning: {msg} (the frames before it are analysed)")
    rep.table(frames.drop(columns=["atoms_file", "bonds_file"]), "one row per frame")
    rep.figure(out / "plots" / "nm.png", "N(M) per frame")
    rep.figure(out / "plots" / "grains.png", "atoms coloured by grain, last frame")
    write_report(rep, out)
    return {"frames": len(steps), "steps": steps, "dimension": dim,
            "n_grains_last": int(frames.n_grains.iloc[-1]), "out": str(out), "warnings": problems}
