"""The records LAMMPS writes for the analysis (`fix print` into thermo.dat), declared once: each
field's name, unit, meaning and the LAMMPS expression that prints it.

The input templates render a record as its `fix print` line with a title line holding the
field names (`# step time ...`); read_record maps the columns by that title, never by
position, and refuses a file whose title lacks a field the reader needs or whose title lines
disagree (a run resumed by another version of the tool appends its own title).
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import pandas as pd


@dataclass(frozen=True)
class Field:
    """One column: name (the title's word), unit, meaning, and the `$(...)` body that prints it."""

    name: str
    unit: str
    meaning: str
    lammps: str


@dataclass(frozen=True)
class Record:
    """A `fix print` record: its fields in print order."""

    name: str
    fields: tuple[Field, ...]

    @property
    def names(self) -> list[str]:
        return [f.name for f in self.fields]

    def print_text(self) -> str:
        """The quoted text of the `fix print` command."""
        return '"' + " ".join(f"$({f.lammps})" for f in self.fields) + '"'

    def title(self) -> str:
        """The `title` keyword of the `fix print` command: '# ' and the field names."""
        return f'title "# {" ".join(self.names)}"'

    def column(self, name: str) -> int:
        """Position of a field (the progress display reads the last line by position)."""
        return self.names.index(name)

    def describe(self) -> str:
        """A Markdown table of the fields (name, unit, meaning), for the docs."""
        rows = [f"| `{f.name}` | {f.unit or '-'} | {f.meaning} |" for f in self.fields]
        return "\n".join(["| field | unit | meaning |", "|---|---|---|", *rows])


class RecordError(ValueError):
    """A record file that cannot be read by its header."""


def _g(expr: str, digits: int = 12) -> str:
    return f"{expr}:%.{digits}g"


# ---------------------------------------------------------------------- BCM impact (SPEC 1.4-1.5)
# f_BCM_GRIFFITH: bond bcm/griffith's sums (plugins/doc/bond_bcm_griffith.md); f_plane: fix
# bcm/wall's (fix_bcm_wall.md); c_cpair: pair bcm/contact's (pair_bcm_contact.md).
IMPACT_RECORD = Record("impact", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time", _g("time", 10)),
    Field("ke_trans", "J", "translational kinetic energy of the cells", _g("c_ket")),
    Field("ke_rot", "J", "rotational kinetic energy of the cells (fix bcm/rigid)", _g("f_integrate")),
    Field("intact", "", "intact interfaces", "f_BCM_GRIFFITH[1]"),
    Field("broken", "", "broken interfaces", "f_BCM_GRIFFITH[2]"),
    Field("broken_area", "m^2", "area of the broken interfaces, A", _g("f_BCM_GRIFFITH[3]")),
    Field("W_f", "J", "fracture energy booked at the breaks (Griffith convention)", _g("f_BCM_GRIFFITH[4]")),
    Field("E_interfaces", "J", "elastic energy stored in the interfaces now", _g("f_BCM_GRIFFITH[5]")),
    Field("W_damp", "J", "energy dissipated by the interfaces' damping", _g("f_BCM_GRIFFITH[6]")),
    Field("W_friction", "J", "energy dissipated by friction on broken interfaces", _g("f_BCM_GRIFFITH[7]")),
    Field("W_switch", "J", "energy lost when interfaces switch (break, retire)", _g("f_BCM_GRIFFITH[8]")),
    # the broken interfaces now (diagnostics of their law; records of runs before them lack these)
    Field("broken_closed", "", "broken interfaces with a closed point (touching, not retired)", "f_BCM_GRIFFITH[9]"),
    Field("closed_points", "", "closed points of broken interfaces", "f_BCM_GRIFFITH[10]"),
    Field("closed_force", "N", "normal force carried by the closed points of broken interfaces",
          _g("f_BCM_GRIFFITH[11]")),
    Field("slip", "m", "cumulative Coulomb slip on broken interfaces, summed over their points",
          _g("f_BCM_GRIFFITH[12]")),
    Field("W_damp_broken", "J", "part of W_damp dissipated by broken interfaces after their break",
          _g("f_BCM_GRIFFITH[13]")),
    Field("wall_contacts", "", "cells touching the plane", "f_plane[1]"),
    Field("wall_force", "N", "normal force of the plane", _g("f_plane[2]")),
    Field("W_wall", "J", "energy dissipated by the plane (all channels)", _g("f_plane[3]")),
    Field("E_wall", "J", "elastic energy stored in the plane's contacts", _g("f_plane[4]")),
    Field("W_wall_damp", "J", "plane: damping", _g("f_plane[5]")),
    Field("W_wall_friction", "J", "plane: friction", _g("f_plane[6]")),
    Field("W_wall_npoints", "J", "plane: changes of a contact's number of points (0 under the per-point law)",
          _g("f_plane[7]")),
    Field("work_wall", "J", "work of the plane's forces on the cells (a check)", _g("f_plane[8]")),
    Field("E_contacts", "J", "elastic energy stored in cell-cell contacts", _g("c_cpair")),
    Field("W_contact_damp", "J", "cell-cell contacts: damping", _g("c_cpair[4]")),
    Field("W_contact_friction", "J", "cell-cell contacts: friction", _g("c_cpair[5]")),
    Field("W_contact_npoints", "J", "cell-cell contacts: tangential springs dropped with their history",
          _g("c_cpair[6]")),
    Field("work_contacts", "J", "work of the cell-cell contact forces on the cells (a check)", _g("c_cpair[7]")),
))

#: IMPACT_RECORD fields that records of runs made before them lack (read when present)
IMPACT_DIAGNOSTICS = ("broken_closed", "closed_points", "closed_force", "slip", "W_damp_broken")

def _wall_fields(walls: tuple[str, ...], what: str, which: str) -> tuple[Field, ...]:
    """The energy fields of a set of fix bcm/wall (their ids), summed over them: what they
    dissipate by channel, store and do (fix_bcm_wall.md: [3]-[8])."""
    def total(k: int) -> str:
        return _g("+".join(f"f_{w}[{k}]" for w in walls))

    return (
        Field("W_wall", "J", f"energy dissipated by {what} (all channels, {which})", total(3)),
        Field("E_wall", "J", f"elastic energy stored in {what}' contacts", total(4)),
        Field("W_wall_damp", "J", f"{what.removeprefix('the ')}: damping", total(5)),
        Field("W_wall_friction", "J", f"{what.removeprefix('the ')}: friction", total(6)),
        Field("W_wall_npoints", "J", f"{what.removeprefix('the ')}: changes of a contact's number of points (0 under "
                                     "the per-point law)", total(7)),
        Field("work_wall", "J", f"work of {what}' forces on the cells (a check)", total(8)),
    )


#: the six walls of a bed (driver/bcm/compress.py WALLS)
BED_WALLS = ("bottom", "top", "xlo", "xhi", "ylo", "yhi")


# ------------------------------------------------------------ BCM crush (SPEC 4.1)
# f_upper, f_lower: the two platens, fix bcm/wall zhi (moving) and zlo (fixed); v_top0: the
# upper platen's position at the start, v_A0: the bonded interface area (lammps_inputs/bcm_crush.in).
# The interface and contact fields are the impact's.
_IMPACT_FIELDS = {f.name: f for f in IMPACT_RECORD.fields}
CRUSH_RECORD = Record("crush", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time", _g("time", 10)),
    Field("platen_z", "m", "the upper platen's position", _g("f_upper[9]", 15)),
    Field("displacement", "m", "the upper platen's travel since the start (closing positive)",
          _g("v_top0-f_upper[9]", 12)),
    Field("gap", "m", "distance between the platens", _g("f_upper[9]-f_lower[9]", 15)),
    Field("F_upper", "N", "normal force on the upper (moving) platen", _g("f_upper[2]")),
    Field("F_lower", "N", "normal force on the lower (fixed) platen", _g("f_lower[2]")),
    Field("W_p", "J", "work of the platens on the cells, integral of F v_p dt (the energy input)",
          _g("f_upper[11]+f_lower[11]")),
    *(_IMPACT_FIELDS[n] for n in ("ke_trans", "ke_rot", "intact", "broken", "broken_area")),
    Field("D_w", "", "damage: broken interface area / bonded area A_0", _g("f_BCM_GRIFFITH[3]/v_A0")),
    *(_IMPACT_FIELDS[n] for n in ("W_f", "E_interfaces", "W_damp", "W_friction", "W_switch")),
    Field("upper_contacts", "", "cells touching the upper platen", "f_upper[1]"),
    Field("lower_contacts", "", "cells touching the lower platen", "f_lower[1]"),
    *_wall_fields(("upper", "lower"), "the platens", "both"),
    *(_IMPACT_FIELDS[n] for n in ("E_contacts", "W_contact_damp", "W_contact_friction", "W_contact_npoints",
                                  "work_contacts")),
))

# ------------------------------------------------------------ BCM bed in confined compression (issue 25)
# six fix bcm/wall (bottom, top, xlo, xhi, ylo, yhi); v_wall_*: their sums (driver/bcm/compress.py)
COMPRESS_RECORD = Record("compress", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time", _g("time", 10)),
    Field("phase", "", "0 fill (breaking off), 1 rest, 2 load, 3 hold, 4 unload, 5 done", "v_phase"),
    Field("height", "m", "the top platen's height above the bottom wall", _g("v_height", 15)),
    Field("sigma_v", "Pa", "vertical stress on the top platen", _g("v_sv")),
    Field("sigma_v_bottom", "Pa", "vertical stress on the bottom wall", _g("v_sv_bottom")),
    Field("sigma_x", "Pa", "lateral stress on the x walls (mean of the two)", _g("v_sx")),
    Field("sigma_y", "Pa", "lateral stress on the y walls (mean of the two)", _g("v_sy")),
    Field("void_ratio", "", "void ratio e = box volume / solid volume - 1", _g("v_void", 12)),
    Field("W_p", "J", "work of the walls on the cells, integral of F v dt (the top platen's: the others are still)",
          _g("v_wall_Wp")),
    *(_IMPACT_FIELDS[n] for n in ("ke_trans", "ke_rot", "intact", "broken", "broken_area", "W_f", "E_interfaces",
                                  "W_damp", "W_friction", "W_switch")),
    Field("top_contacts", "", "cells touching the top platen", "f_top[1]"),
    Field("bottom_contacts", "", "cells touching the bottom wall", "f_bottom[1]"),
    Field("side_contacts", "", "cells touching the four side walls", "v_wall_side"),
    *_wall_fields(BED_WALLS, "the walls", "all six"),
    *(_IMPACT_FIELDS[n] for n in ("E_contacts", "W_contact_damp", "W_contact_friction", "W_contact_npoints",
                                  "work_contacts")),
))

# ------------------------------------------------- BCM block calibration (SPEC 3, cells of SPEC 1.1-1.2)
# pressure tensor: virial (rigid-body virial of the interfaces and contacts, from the cell
# centres) plus kinetic parts, SI units; the f_BCM_GRIFFITH sums as in IMPACT_RECORD.
BCM_BLOCK_RECORD = Record("bcm_block", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time", _g("time", 10)),
    Field("phase", "", "deformation phase (driver/bcm/calibrate.py; 0 for the fracture pull)", "v_phase"),
    Field("strain", "", "strain of the phase: volumetric (compression), shear (tilt / length) or the pull's "
                        "engineering strain", _g("v_strain", 10)),
    *(Field(f"p{ij}", "Pa", f"pressure tensor component {ij} (virial + kinetic)", _g(f"c_thermo_press[{k}]", 10))
      for k, ij in enumerate(("xx", "yy", "zz", "xy", "xz", "yz"), start=1)),
    Field("vol", "m^3", "box volume", _g("vol", 12)),
    Field("ke_trans", "J", "translational kinetic energy of the cells", _g("c_ket")),
    Field("ke_rot", "J", "rotational kinetic energy of the cells (fix bcm/rigid)", _g("f_integrate")),
    Field("bonds_broken", "", "broken interfaces", "f_BCM_GRIFFITH[2]"),
    Field("broken_area", "m^2", "area of the broken interfaces", _g("f_BCM_GRIFFITH[3]")),
    Field("W_f", "J", "fracture energy booked at the breaks (Griffith convention)", _g("f_BCM_GRIFFITH[4]")),
    Field("E_interfaces", "J", "elastic energy stored in the interfaces now", _g("f_BCM_GRIFFITH[5]")),
    Field("W_damp", "J", "energy dissipated by the interfaces' damping", _g("f_BCM_GRIFFITH[6]")),
    Field("W_switch", "J", "energy lost when interfaces switch (break, retire)", _g("f_BCM_GRIFFITH[8]")),
    Field("E_contacts", "J", "elastic energy stored in cell-cell contacts", _g("c_cpair")),
))

# ------------------------------------------------------------- BPM impact (SPEC 1.4-1.5, 3)
# LJ units but the time (the analysis converts to SI with system.json's a, m, u). f_plane: fix
# wall/gran's per-atom contact forces, reduced in c_wall (lammps_inputs/bpm_impact.in).
BPM_IMPACT_RECORD = Record("bpm_impact", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time (time tau)", _g("v_time_s", 10)),
    Field("ke", "u", "kinetic energy of the particles (translation: point particles)", _g("c_ket")),
    Field("E_pair", "u", "non-bonded repulsion energy (Eq. 1)", _g("c_pep")),
    Field("E_bonds", "u", "energy stored in intact bonds (Eq. 2)", _g("c_peb")),
    Field("E_angles", "u", "energy stored in intact angles (Eq. 3-4)", _g("c_pea")),
    Field("wall_contacts", "", "particles touching the plane", "c_wall[1]"),
    Field("E_wall", "u", "energy of the plane's normal springs (tangential springs not included)", _g("c_wall[2]")),
    Field("work_wall", "u", "work of the plane's forces on the particles since the start", _g("v_wall_work")),
    Field("wall_force", "u/a", "normal force of the plane", _g("c_wall[4]")),
    Field("W_damp_pair", "u", "energy dissipated by the damping of non-bonded pairs (Eq. 5)", _g("v_damp_pair")),
    Field("W_damp_bond", "u", "energy dissipated by the damping of bonds (Eq. 5)", _g("v_damp_bond")),
    Field("bonds_broken", "", "broken bonds", "f_BREAKABLE_SPECIAL[1]"),
    Field("angles_broken", "", "broken angles", "f_BREAKABLE_SPECIAL[2]"),
    Field("vcm_z", "a/tau", "centre-of-mass velocity along the plane normal", _g("vcm(all,z)")),
))

# ------------------------------------------------------------------ BPM crush (SPEC 4.1, 3)
# LJ units but the time, as BPM_IMPACT_RECORD. The lower plane z = 0 is fix wall/gran `plane`
# (c_wall as the impact's); the upper platen fix wall/gran/region `upper` (driver/bpm/platen.py:
# c_upper_f, v_upper_load, c_upper_springs); the running integrals are lammps_inputs/bpm_crush.in's.
BPM_CRUSH_RECORD = Record("bpm_crush", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time (time tau)", _g("v_time_s", 10)),
    Field("displacement", "a", "the upper platen's travel since the start (closing positive)", _g("-v_upper_dz", 12)),
    Field("gap", "a", "distance between the platens", _g("v_upper_z", 15)),
    Field("F_upper", "u/a", "normal force on the upper (moving) platen", _g("v_upper_load")),
    Field("F_lower", "u/a", "normal force on the lower (fixed) plane", _g("c_wall[4]")),
    Field("W_p", "u", "work of the platen, integral of F_p . v_p dt (the energy input)", _g("v_platen_work")),
    Field("ke", "u", "kinetic energy of the particles (translation: point particles)", _g("c_ket")),
    Field("E_pair", "u", "non-bonded repulsion energy (Eq. 1)", _g("c_pep")),
    Field("E_bonds", "u", "energy stored in intact bonds (Eq. 2)", _g("c_peb")),
    Field("E_angles", "u", "energy stored in intact angles (Eq. 3-4)", _g("c_pea")),
    Field("lower_contacts", "", "particles touching the lower plane", "c_wall[1]"),
    Field("upper_contacts", "", "particles touching the upper platen", "c_upper_f[1]"),
    Field("E_wall_lower", "u", "energy of the lower plane's normal springs", _g("c_wall[2]")),
    Field("E_wall_upper", "u", "energy of the upper platen's normal springs", _g("c_upper_springs")),
    Field("work_lower", "u", "work of the lower plane's forces on the particles", _g("v_wall_work")),
    Field("work_upper", "u", "work of the upper platen's forces on the particles", _g("v_upper_work")),
    Field("W_damp_pair", "u", "energy dissipated by the damping of non-bonded pairs (Eq. 5)", _g("v_damp_pair")),
    Field("W_damp_bond", "u", "energy dissipated by the damping of bonds (Eq. 5)", _g("v_damp_bond")),
    Field("bonds_broken", "", "broken bonds", "f_BREAKABLE_SPECIAL[1]"),
    Field("angles_broken", "", "broken angles", "f_BREAKABLE_SPECIAL[2]"),
))

# ------------------------------------------------------------ BPM bed in confined compression (issue 25)
# LJ units (the analysis converts to SI: analysis/bed_run.py read_bpm_compress_record); the
# walls and the platen of lammps_inputs/bpm_compress.in.
BPM_COMPRESS_RECORD = Record("bpm_compress", (
    Field("step", "", "time step", "step"),
    Field("time", "s", "simulated time (time tau)", _g("v_time_s", 10)),
    Field("phase", "", "0 fill (breaking off), 1 rest, 2 load, 3 hold, 4 unload, 5 done", "v_phase"),
    Field("height", "a", "the top platen's height above the bottom wall", _g("v_height", 15)),
    Field("sigma_v", "u/a^3", "vertical stress on the top platen", _g("v_sv")),
    Field("sigma_v_bottom", "u/a^3", "vertical stress on the bottom wall", _g("v_sv_bottom")),
    Field("sigma_x", "u/a^3", "lateral stress on the x walls (mean of the two)", _g("v_sx")),
    Field("sigma_y", "u/a^3", "lateral stress on the y walls (mean of the two)", _g("v_sy")),
    Field("void_ratio", "", "void ratio e = box volume / solid volume - 1", _g("v_void", 12)),
    Field("W_p", "u", "work of the top platen, integral of F_p . v_p dt (the energy input)", _g("v_platen_work")),
    Field("ke", "u", "kinetic energy of the particles (translation: point particles)", _g("c_ket")),
    Field("E_pair", "u", "non-bonded repulsion energy (Eq. 1)", _g("c_pep")),
    Field("E_bonds", "u", "energy stored in intact bonds (Eq. 2)", _g("c_peb")),
    Field("E_angles", "u", "energy stored in intact angles (Eq. 3-4)", _g("c_pea")),
    Field("E_walls", "u", "energy of the five fixed walls' normal springs", _g("c_springs[1]")),
    Field("E_top", "u", "energy of the top platen's normal springs", _g("c_springs[2]")),
    Field("work_walls", "u", "work of the fixed walls' forces on the particles", _g("v_walls_work")),
    Field("work_top", "u", "work of the top platen's forces on the particles", _g("v_top_work")),
    Field("W_damp_pair", "u", "energy dissipated by the damping of non-bonded pairs (Eq. 5)", _g("v_damp_pair")),
    Field("W_damp_bond", "u", "energy dissipated by the damping of bonds (Eq. 5)", _g("v_damp_bond")),
    Field("top_contacts", "", "particles touching the top platen", "c_top_f[1]"),
    Field("bottom_contacts", "", "particles touching the bottom wall", "c_bottom_f[1]"),
    Field("side_contacts", "", "particles touching the four side walls", "v_side_contacts"),
    Field("bonds_broken", "", "broken bonds", "f_BREAKABLE_SPECIAL[1]"),
    Field("angles_broken", "", "broken angles", "f_BREAKABLE_SPECIAL[2]"),
))

# ------------------------------------------------------------------------ BPM shear (SPEC 2.4-2.5)
# pressure tensor: virial + kinetic parts (compute pressure of thermo_style), LJ units
SHEAR_RECORD = Record("shear", (
    Field("step", "", "time step", "step"),
    Field("strain", "", "true strain eps = edot t", _g("v_strain", 8)),
    *(Field(f"p{ij}", "u/a^d", f"pressure tensor component {ij} (virial + kinetic)", _g(f"c_thermo_press[{k}]", 10))
      for k, ij in enumerate(("xx", "yy", "zz", "xy", "xz", "yz"), start=1)),
    Field("pe", "u", "potential energy per particle", _g("pe", 10)),
    Field("ke", "u", "kinetic energy per particle", _g("ke", 10)),
    Field("vol", "a^d", "box volume (area in 2D)", _g("vol", 10)),
    Field("bonds_broken", "", "broken bonds", "f_BREAKABLE_SPECIAL[1]"),
    Field("angles_broken", "", "broken angles", "f_BREAKABLE_SPECIAL[2]"),
))

# ------------------------------------------------------------------ BPM moduli (SPEC 2.3)
MODULI_RECORD = Record("moduli", (
    Field("step", "", "time step", "step"),
    Field("phase", "", "deformation phase (driver/bpm/moduli.py: compression, shear planes, at rate then rate/2)",
          "v_phase"),
    Field("strain", "", "strain of the phase: volumetric (compression) or shear (tilt / length)", _g("v_strain", 10)),
    *(f for f in SHEAR_RECORD.fields[2:]),
))


# ------------------------------------------------------------------ BPM mode-I toughness (SPEC 2.3)
MODE1_RECORD = Record("mode1", (
    Field("step", "", "time step", "step"),
    Field("time", "tau", "simulated time", _g("time", 10)),
    Field("displacement", "a", "separation of the grips minus its initial value (2 v t)", _g("v_displacement", 10)),
    Field("stress", "u/a^d", "far-field stress on the grips (F_bottom,y - F_top,y) / (2 W), driver/bpm/mode1.py",
          _g("v_stress", 10)),
    Field("pe", "u", "potential energy per particle", _g("pe", 10)),
    Field("ke", "u", "kinetic energy per particle", _g("ke", 10)),
    Field("bonds_broken", "", "broken bonds", "f_BREAKABLE_SPECIAL[1]"),
    Field("angles_broken", "", "broken angles", "f_BREAKABLE_SPECIAL[2]"),
))

# ------------------------------------------------------------------ BPM mode-II toughness (SPEC 2.3)
# pressure tensor: virial + kinetic parts over the box area (void included), LJ units
MODE2_RECORD = Record("mode2", (
    Field("step", "", "time step", "step"),
    Field("time", "tau", "simulated time", _g("time", 10)),
    Field("strain", "", "true strain of the pure shear eps = edot t (x stretched, y compressed)", _g("v_strain", 10)),
    *(Field(f"p{ij}", "u/a^d", f"pressure tensor component {ij} (virial + kinetic)", _g(f"c_thermo_press[{k}]", 10))
      for k, ij in ((1, "xx"), (2, "yy"), (4, "xy"))),
    Field("tau", "u/a^d", "shear stress on the 45-degree planes (sigma_xx - sigma_yy) / 2 = (p_yy - p_xx) / 2, "
          "driver/bpm/mode2.py", _g("v_tau", 10)),
    Field("pe", "u", "potential energy per particle", _g("pe", 10)),
    Field("ke", "u", "kinetic energy per particle", _g("ke", 10)),
    Field("bonds_broken", "", "broken bonds", "f_BREAKABLE_SPECIAL[1]"),
    Field("angles_broken", "", "broken angles", "f_BREAKABLE_SPECIAL[2]"),
))

def read_record(path: str | Path, needed: list[str]) -> pd.DataFrame:
    """The record file `path` as a table whose columns are named by its title line; RecordError
    when it has no title, when its title lines differ, or when a `needed` field is missing.
    Each `run` command prints its first step again: the latest record of a step is kept."""
    path = Path(path)
    text = path.read_text()
    titles = sorted({ln for ln in text.splitlines() if ln.startswith("#")})
    if not titles:
        raise RecordError(f"{path}: no title line ('# name name ...'): cannot tell its columns")
    if len(titles) > 1:
        raise RecordError(f"{path}: its title lines differ ({' | '.join(t[:80] for t in titles)}): records of "
                          "two layouts in one file")
    names = titles[0][1:].split()
    missing = [n for n in needed if n not in names]
    if missing:
        raise RecordError(f"{path}: no column {', '.join(missing)} in its title ({' '.join(names)})")
    df = pd.read_csv(io.StringIO(text), sep=r"\s+", comment="#", names=names, header=None)
    return df.drop_duplicates("step", keep="last").reset_index(drop=True)


# ------------------------------------------------------------------------------------ dumps
@dataclass(frozen=True)
class Column:
    """One dump column: its name in the file (one OVITO maps by itself where it has one), unit,
    meaning, and the dump argument that writes it (renamed with dump_modify colname), or the
    value keyword of the plugin's interface dump (renamed with its `names`)."""

    name: str
    unit: str
    meaning: str
    lammps: str = ""

    @property
    def arg(self) -> str:
        return self.lammps or self.name


@dataclass(frozen=True)
class Dump:
    """The columns of one kind of dump file, in order."""

    name: str
    columns: tuple[Column, ...]

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.columns]

    def args(self) -> str:
        """The dump command's column arguments."""
        return " ".join(c.arg for c in self.columns)

    def modify(self) -> str:
        """dump_modify keywords giving each renamed column its name (`colname N name`)."""
        return " ".join(f"colname {k} {c.name}" for k, c in enumerate(self.columns, start=1) if c.arg != c.name)

    def names_keyword(self) -> str:
        """The `names` keyword naming every column, for the plugin's interface dump (fix
        bcm/interfaces/dump, write_bcm_interfaces)."""
        return "names " + " ".join(self.names)

    def describe(self) -> str:
        """A Markdown table of the columns (name, unit, meaning), for the docs."""
        rows = [f"| `{c.name}` | {c.unit or '-'} | {c.meaning} |" for c in self.columns]
        return "\n".join(["| column | unit | meaning |", "|---|---|---|", *rows])


# BCM: one atom per cell (SPEC 1.1); the orientation is atom_style bpm/sphere's quaternion, from
# the compute bcm_quat of driver/bcm/lammps_files.py (QUAT_COMPUTE), named as OVITO's and
# LAMMPS's quaternion columns (dumps of runs up to main fc0b266 wrote d2_bcm_quat[k] under the
# same names); radius: the cell's bounding sphere
CELLS_DUMP = Dump("cells", (
    Column("id", "", "cell id"), Column("mass", "kg", "cell mass"),
    Column("x", "m", "centroid x"), Column("y", "m", "centroid y"), Column("z", "m", "centroid z"),
    Column("vx", "m/s", "velocity x"), Column("vy", "m/s", "velocity y"), Column("vz", "m/s", "velocity z"),
    Column("omegax", "1/s", "angular velocity x"), Column("omegay", "1/s", "angular velocity y"),
    Column("omegaz", "1/s", "angular velocity z"),
    Column("radius", "m", "radius of the cell's bounding sphere (neighbour lists)"),
    *(Column(f"quat{c}", "", f"orientation quaternion, component {c} (body to space)", f"c_bcm_quat[{k}]")
      for k, c in enumerate("wijk", start=1)),
))
# BCM interfaces (fix bcm/interfaces/dump and write_bcm_interfaces of the plugin,
# plugins/doc/fix_bcm_interfaces_dump.md: each column's value keyword, batom1 batom2 of the bond
# and b1..b13 of bond bcm/griffith's single(), plugins/doc/bond_bcm_griffith.md; the file is
# that of `dump local` of compute property/local and compute bond/local, which dumps of earlier
# runs came from)
INTERFACES_DUMP = Dump("interfaces", (
    Column("batom1", "", "cell 1 (smaller id)"),
    Column("batom2", "", "cell 2"),
    Column("state", "", "1 intact, 0 broken", "b1"),
    Column("area", "m^2", "interface area", "b2"),
    Column("energy", "J", "elastic energy stored now", "b3"),
    Column("break_step", "", "step of the break (-1 intact)", "b4"),
    Column("break_time", "s", "time of the break", "b5"),
    Column("energy_at_break", "J", "elastic energy stored just before the break", "b6"),
    # where each interface's energy went (dumps of runs before these columns lack them)
    Column("W_damp", "J", "energy its damping dissipated (intact and broken)", "b7"),
    Column("W_damp_broken", "J", "the part of W_damp after its break", "b8"),
    Column("W_friction", "J", "energy its friction dissipated (broken)", "b9"),
    Column("W_switch", "J", "energy lost at its switches (break, retirement)", "b10"),
    Column("slip", "m", "cumulative Coulomb slip of its points", "b11"),
    Column("closed_points", "", "its closed points now (broken, not retired)", "b12"),
    Column("closed_force", "N", "normal force of its closed points now", "b13"),
))
#: the INTERFACES_DUMP columns every interface dump has (the rest came later)
INTERFACES_REQUIRED = 8


def atoms_dump(dimension: int, grain: bool = False) -> Dump:
    """BPM particles: 2D dumps have no z and no vz column, which OVITO takes as a 2D cell;
    grain: a bed's particles also carry their grain id (the LAMMPS molecule id)."""
    axes = "xy" if dimension == 2 else "xyz"
    return Dump("atoms", (
        Column("id", "", "particle id"), Column("type", "", "particle type (2D: 1 small, 2 large)"),
        *(Column(a, "a", f"position {a}") for a in axes),
        *(Column(f"v{a}", "a/tau", f"velocity {a}") for a in axes),
        Column("radius", "a", "particle radius", "v_radius"),
        *((Column("mol", "", "grain id (LAMMPS molecule id; driver/bpm/bed.py)"),) if grain else ()),
    ))


# BPM bonds (dump local of compute property/local batom1 batom2 btype, ID bl): intact bonds
BONDS_DUMP = Dump("bonds", (
    Column("batom1", "", "particle 1", "c_bl[1]"),
    Column("batom2", "", "particle 2", "c_bl[2]"),
    Column("btype", "", "bond type (broken bonds are not listed)", "c_bl[3]"),
))
