"""`driver post FILE...`: grains from dump files named on the command line (no run directory,
e.g. dumps of a run made elsewhere).

Atom dumps (`dump custom` with id and x y [z], optionally type, vx vy vz, mass, radius) and
bond dumps (`dump local` with the two atom ids and a type or state: > 0 intact, <= 0 broken,
as both models' dumps write them) are told apart by their headers and paired by timestep.
Columns are found by their header names, in any order (analysis.dumps: `bond_columns` for
the bond dumps, an `index` column skipped); a dump lacking a needed column, or whose names do
not tell, is refused with the names it has. Every paired frame gives a grain table, N(M),
moments and a row of the frame table; consecutive frames give the parent-child tracking
table. Grain masses M in N(M), the moments and tau are particle counts (SPEC 2.5's unit: the
particle mass); the grain table also has each grain's mass from the dump's mass column (1 per
atom without one).

Checks, before any result is written: the dimension (given or inferred) against the z
column and the box (`frame_dimension`). Flags, which go into the summary (`warnings`,
`flags`), the frame table and the report, the frames still analysed: atoms with non-finite
coordinates (their grains have no valid centre of mass or gyration), and tau fits that are no
result (analysis.powerlaw.exponent_flag: tau outside (1, 3], fewer than 10 grains fitted),
whose number is kept beside a `tau_flag`.
"""

from __future__ import annotations

import gzip
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import pandas as pd

from analysis.dumps import COORDINATE_CONVENTIONS, AtomFrame, DumpError, iter_atom_dump, iter_local_dump, read_atom_dump
from analysis.grain_table import frame_grains
from analysis.pictures import render_particles_2d, render_particles_3d
from analysis.plots import plot_nm
from analysis.powerlaw import MIN_FIT_GRAINS, exponent_flag, grains_fitted
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


def frame_dimension(frame: AtomFrame, path: Path, dimension: int | None = None,
                    given: str = "--dimension") -> int:
    """2 or 3: the dimension of an atom frame, checked against `dimension` when given.

    A LAMMPS 2D dump has every z equal (or no z column) and a box periodic in z (LAMMPS runs
    2D only so); z that varies is 3D. Refused (DumpError naming the file, the timestep and
    what was found): a frame without coordinate columns; `dimension` 3 on a frame without a z
    column or with every z equal; 2 on a frame whose z varies; a flat frame whose box is not
    periodic in z. `given` names where `dimension` came from, for the message. Non-finite z
    values are left to the non-finite flag.
    """
    where = f"{path}: atom dump at timestep {frame.timestep}"
    found = " ".join(frame.names)
    if frame.positions is None:
        conventions = ", ".join(" ".join(c) for c in COORDINATE_CONVENTIONS.values())
        raise DumpError(f"{where} has no coordinate columns; found: {found}; needed: id and one of {conventions} "
                        "(without the z column in 2D)")
    z = frame.positions[:, 2] if frame.positions.shape[1] == 3 else None
    zf = z[np.isfinite(z)] if z is not None else np.zeros(0)
    flat = len(zf) == 0 or np.ptp(zf) == 0
    z_periodic = len(frame.boundary) < 3 or frame.boundary[2].startswith("p")
    if dimension == 3 and z is None:
        raise DumpError(f"{where}: {given} 3, but the dump has no z column (found: {found})")
    if dimension == 3 and flat:
        raise DumpError(f"{where}: {given} 3, but every atom has z = {zf[0] if len(zf) else float('nan'):g} in a "
                        f"box periodic in z from {frame.box[2, 0]:g} to {frame.box[2, 1]:g}: a 2D dump"
                        if z_periodic else f"{where}: {given} 3, but every atom has z = "
                        f"{zf[0] if len(zf) else float('nan'):g}: a flat layer, no 3D solid")
    if dimension == 2 and not flat:
        raise DumpError(f"{where}: {given} 2, but z spans {zf.min():g}..{zf.max():g}: a 3D dump")
    if flat and not z_periodic:
        raise DumpError(f"{where}: every atom has the same z, but the box is not periodic in z (boundary "
                        f"{' '.join(frame.boundary)}), as LAMMPS needs in 2D: neither a 2D dump nor a 3D solid")
    return 2 if flat else 3


def _nonfinite_ids(frame: AtomFrame) -> np.ndarray:
    """Ids of the atoms with a non-finite coordinate."""
    return frame.ids[~np.isfinite(frame.positions).all(axis=1)]


def analyse_dump_files(files: list[Path], out: Path, dimension: int | None = None, plots: bool = True,
                       m_min: float | None = None, reader: str = "numpy", count_above: tuple[float, ...] = (10, 100),
                       log: Callable[[str], None] | None = None) -> dict:
    """Grain tables, N(M), frame table, tracking, plots and report of the paired frames of
    `files` into `out`. dimension: 2 or 3 (default: 2 when every z is equal), checked against
    every atom frame (`frame_dimension`); m_min: the
    small-grain cut of N(M) (default SPEC 2.5's for the dimension); count_above: further
    thresholds whose grain counts the frame table holds; reader: the atom-dump
    engine of analysis.dumps.read_atom_dump ("numpy", or "mdanalysis" for MDAnalysis'
    DumpReader positions and velocities); log: called with a line per frame (progress) and
    per problem. Frames are streamed: one atom and one bond frame in memory at a time. A
    truncated dump ends its file's frames with a warning; the frames before it are analysed.

    Returns the summary: frames, steps, dimension, n_grains_last, tau_last and tau_last_flag
    (the last frame's fit: None when it is a result, else why not), out, warnings (one line
    per problem or flag), flags ({"nonfinite_coordinates": steps, "tau": steps}: the
    timesteps flagged)."""
    files = [Path(f) for f in files]
    out = Path(out)
    log = log or (lambda _msg: None)
    problems: list[str] = []
    grain_rows, nm_rows, frame_rows, labels_seq, steps = [], [], [], [], []
    nonfinite: list[str] = []
    flagged: list[str] = []  # tau fits that are no result
    ids0 = dim = cut = thresholds = last = None
    for af, file_a, bf, file_b in paired_frames(files, reader, problems):
        if ids0 is None:
            ids0 = af.ids
            dim = frame_dimension(af, file_a, dimension)
            cut = m_min if m_min is not None else SMALL_GRAIN_CUT[dim]
            thresholds = tuple(t for t in count_above if t != cut)
            clear_report(out)
        else:
            if not np.array_equal(af.ids, ids0):
                raise DumpError(f"{file_a}: timestep {af.timestep} holds other atoms than timestep {steps[0]}: "
                                "tracking needs the same atoms in every frame")
            frame_dimension(af, file_a, dim, given=f"dimension of timestep {steps[0]} =")
        step = af.timestep
        bad_ids = _nonfinite_ids(af)
        if len(bad_ids):
            shown = ", ".join(map(str, bad_ids[:5])) + (" ..." if len(bad_ids) > 5 else "")
            nonfinite.append(f"{file_a}, timestep {step}: {len(bad_ids)} atom(s) with non-finite coordinates "
                             f"(atom id {shown}); the grains holding them have no valid centre of mass or gyration")
            log(f"warning: {nonfinite[-1]}")
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
        perc = table["percolating"].to_numpy()
        fit = fit_grain_tau(masses, cut, perc, n_bootstrap=200, min_grains=MIN_FIT_GRAINS)
        n_fit = fit.n if fit is not None else grains_fitted(masses, cut, perc)
        flag = exponent_flag(None if fit is None else fit.tau, n_fit)
        if flag:
            flagged.append(f"timestep {step}: tau is not a result: {flag}")
        frame_rows.append({"step": step, "atoms_file": str(file_a), "bonds_file": str(file_b),
                           "n_atoms": len(af.ids), "nonfinite_atoms": len(bad_ids),
                           **frame_measures(masses, table["percolating"], cut, thresholds),
                           "largest_grain_mass": float(table["mass"].max()),
                           "tau": None if fit is None else fit.tau, "tau_sigma": None if fit is None else fit.sigma,
                           "tau_sigma_bootstrap": None if fit is None else fit.sigma_bootstrap, "tau_n": 0 if fit is None else fit.n,
                           "tau_flag": flag})
        last = af
        log(f"step {step}: {len(af.ids)} atoms, {len(masses)} grains")
    for msg in problems:
        log(f"warning: {msg}")
    for msg in flagged:
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
    for msg in nonfinite + flagged:
        rep.text(f"Warning: {msg}")
    rep.table(frames.drop(columns=["atoms_file", "bonds_file"]), "one row per frame")
    rep.figure(out / "plots" / "nm.png", "N(M) per frame")
    rep.figure(out / "plots" / "grains.png", "atoms coloured by grain, last frame")
    write_report(rep, out)
    return {"frames": len(steps), "steps": steps, "dimension": dim,
            "n_grains_last": int(frames.n_grains.iloc[-1]),
            "tau_last": frame_rows[-1]["tau"], "tau_last_flag": frame_rows[-1]["tau_flag"],
            "out": str(out), "warnings": problems + nonfinite + flagged,
            "flags": {"nonfinite_coordinates": [r["step"] for r in frame_rows if r["nonfinite_atoms"]],
                      "tau": [r["step"] for r in frame_rows if r["tau_flag"]]}}
