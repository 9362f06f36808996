"""The size model: how big a run is, before anything is built (elements, bonds, peak memory
and time per step), per model and scenario; the units (driver/scenarios/) call it, and
driver/estimate.py gives the estimate of a config through its unit.

The counts follow the builders' own rules without running them (BPM: `particle_count` of
driver/bpm/packing.py and the bond/angle counts per particle of driver/bpm/network.py; BCM:
`n_cells` and the interfaces and contact points per cell of a centroidal Voronoi
tessellation). Memory and time are linear fits to runs measured on the development machine
(the measured figures and commands are written beside each constant): peak resident memory
of `driver run` with one rank, and LAMMPS loop time per 1000 steps. They are estimates to
within a factor of about 2, meant to refuse a run that cannot fit before it starts filling
memory, not to plan a cluster allocation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from driver.schedule import steps_for_strain

if TYPE_CHECKING:  # for readers and checkers only
    from driver.config import RunConfig

GIB = 1024**3
MIB = 1024**2

# Measured on the development machine (2 shared cores, other jobs running; the HEAD tree of
# this repository), one rank, plots off:
#   /usr/bin/time -v python -m driver.cli run CASE.yaml --quiet
# CASE.yaml: the named example with `output: {dir: /tmp/est/run_<tag>, plots: false}` and the
# overrides listed. Memory: "Maximum resident set size" (the whole run: build, LAMMPS,
# analysis). Time: the LAMMPS log's "Loop time of T on 1 procs for S steps" of the main run.

# --- BCM (examples/bcm_impact*.yaml) ------------------------------------------------------
#: Interfaces per cell of a CVT Voronoi tessellation of the parent: I/N = a (1 - b N^(-1/3))
#: (cells at the surface have fewer neighbours); least squares over the measured counts
#: (system.json n_interfaces / n_cells): 300 cells 1716 (5.72), 1728 cells 10854 (6.28),
#: 8000 cells 52652 (6.58); the fit reproduces each within 0.4 %, and 27000 cells (181436,
#: measured afterwards) within 0.03 %.
BCM_INTERFACES_BULK = 7.01
BCM_INTERFACES_SURFACE = 1.233
#: Contact points (interface polygon vertices) per interface: 8775/1716 = 5.11 (300 cells),
#: 55242/10854 = 5.09 (1728), 268731/52652 = 5.10 (8000), 927843/181436 = 5.11 (27000).
BCM_POINTS_PER_INTERFACE = 5.1
#: Lightest over mean cell mass after Lloyd iterations, which sets the time step (from
#: system.json shortest_period): 0.852 (300 cells), 0.816 (1728), 0.769 (8000), 0.804
#: (27000). The smallest is kept, so that the step count is an upper bound.
BCM_MIN_MASS_RATIO = 0.77
#: Peak RSS, kB: 549,124 at 300 cells (bcm_impact_quick.yaml as it is); 603,968 at 1728
#: (bcm_impact.yaml, scenario.max_time 5e-5); 766,932 at 8000 (bcm_impact.yaml, model.n_cells
#: 8000, scenario.max_time and settle_window 1e-6; Lloyd tessellation included, 48 s);
#: 1,768,540 at 27000 (same, n_cells 27000, max_time and settle_window 1e-7; Lloyd 266 s; that
#: run stopped at `pair_style bcm/contact` on a non-planar core face, after the whole build).
#: The growth is faster than linear, so the estimate is the larger of two lines: the least
#: squares line of the three small runs (535 MiB + 27.6 kB per cell) and the line through the
#: 8000 and 27000 runs (337 MiB + 52.7 kB per cell), which takes over above ~8000 cells.
BCM_MEMORY_LINES = ((535 * MIB, 27.6 * 1024), (337 * MIB, 52.7 * 1024))
#: Loop time per cell per 1000 steps (LAMMPS log): 0.475 s / 2158 steps at 300 cells
#: (7.3e-4), 9.5 s / 5292 steps at 1728 cells during impact (1.04e-3), 24.4 s / 2345 steps at
#: 8000 cells (1.30e-3); on 2026-12-02 this host ran 1.8 to 2.6 times slower: the whole
#: 1728-cell impact, 217 s / 37,100 steps (3.4e-3; `python bench/bcm_impact.py`). The largest
#: is kept, so that the cost is an upper bound; a sweep scales it by its own finished runs.
BCM_SECONDS_PER_CELL = 3.4e-3

# --- BPM (examples/bpm_shear_2d.yaml, scenario.max_strain and measure_strains shortened) ---
#: Bonds and angles per particle (driver/bpm/network.py: exactly 3 and 6 on a periodic 2D
#: triangulation; in 3D with the 5/4 a cut, measured 5.63-5.66 bonds and 25.4-25.7 angles per
#: particle at L = 8, 16, 24, 32).
BPM_BONDS_PER_PARTICLE = {2: 3.0, 3: 5.65}
BPM_ANGLES_PER_PARTICLE = {2: 6.0, 3: 25.6}
#: Peak RSS = base + per particle * N, least squares.
#: 2D: L 24 (976 particles) 248,564 kB; L 96 (15,616) 278,180 kB; L 192 (62,464) 372,208 kB
#:     -> 241 MiB + 2.01 kB per particle (within 0.1 MB of each).
#: 3D (model.dimension 3): L 8 (645) 246,444 kB; L 16 (5,163) 271,484 kB; L 24 (17,425)
#:     488,728 kB; L 32 (41,304) 725,148 kB -> 231 MiB + 12.1 kB per particle (within 40 MB).
BPM_MEMORY_BASE = {2: 241 * MIB, 3: 231 * MIB}
BPM_MEMORY_PER_PARTICLE = {2: 2.01 * 1024, 3: 12.1 * 1024}
#: Loop time per particle per 1000 steps.
#: 2D: 2.86 s / 20,000 steps at 976 (1.47e-4), 5.36 s / 2000 at 15,616 (1.72e-4; 2.15e-4 in
#:     a second run), 4.31 s / 400 at 62,464 (1.72e-4).
#: 3D: 1.91 s / 4000 at 645 (7.4e-4), 3.87 s / 1000 at 5,163 (7.5e-4), 2.21 s / 200 at 17,425
#:     (6.3e-4), 5.22 s / 100 at 41,304 (1.26e-3).
BPM_SECONDS_PER_PARTICLE = {2: 1.8e-4, 3: 1.0e-3}

#: With --np N > 1 LAMMPS runs as N `lmp` processes beside the driver: summed RSS of the
#: process tree (polled every 0.1 s) 549,168 kB with 1 rank, 949,276 kB with 2
#: (bcm_impact_quick.yaml, execution.np 2), i.e. about 195 MiB per rank. Time is divided by
#: N (ideal; that run's loop took 0.307 s instead of 0.475 s, a speed-up of 1.55).
RANK_MEMORY = 195 * MIB


@dataclass(frozen=True)
class SizeEstimate:
    """What a configuration will cost.

    elements: cells (BCM) or particles (BPM). bonds: interfaces (BCM) or bonds + angles (BPM).
    memory_bytes: peak resident memory of `driver run` over all ranks.
    seconds_per_1000_steps: LAMMPS time per 1000 steps on the given ranks (ideal scaling).
    steps: steps of the main run (BCM: the `max_time` bound; a run that settles stops earlier).
    """

    model: str
    elements: int
    element_name: str
    bonds: int
    bond_name: str
    memory_bytes: int
    seconds_per_1000_steps: float
    steps: int
    ranks: int = 1

    @property
    def seconds(self) -> float:
        """Estimated LAMMPS time of the whole main run (an upper bound for BCM)."""
        return self.seconds_per_1000_steps * self.steps / 1000.0

    def describe(self) -> str:
        """One line, e.g. 'BPM 2D: ~980 particles, ~8,800 bonds + angles; ~0.55 GiB; ...'."""
        bound = "at most " if self.model == "BCM" else ""
        return (f"{self.model}: ~{self.elements:,} {self.element_name}, ~{self.bonds:,} {self.bond_name}; "
                f"~{self.memory_bytes / GIB:.2f} GiB memory; ~{_duration(self.seconds_per_1000_steps)} per "
                f"1000 steps on {self.ranks} rank{'s' if self.ranks > 1 else ''}, {bound}{self.steps:,} steps "
                f"(~{_duration(self.seconds)})")


def _duration(seconds: float) -> str:
    if seconds < 60:
        return f"{seconds:.2g} s"
    if seconds < 3600:
        return f"{seconds / 60:.2g} min"
    if seconds < 86400 * 2:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 86400:.3g} days"


def _ranks_memory(ranks: int) -> float:
    """One rank runs inside the driver; N > 1 ranks are N extra processes (see RANK_MEMORY)."""
    return RANK_MEMORY * ranks if ranks > 1 else 0.0


def bcm_interfaces(n_cells: int) -> int:
    """Expected interfaces of a CVT tessellation of n_cells (see BCM_INTERFACES_*)."""
    per_cell = BCM_INTERFACES_BULK * (1.0 - BCM_INTERFACES_SURFACE * n_cells ** (-1.0 / 3.0))
    return int(round(max(per_cell, 0.5) * n_cells))


def bcm_timestep(cfg: RunConfig, diameter: float) -> float:
    """SPEC 1.4's time step, as driver/bcm/particle.py contact_timestep, for a particle of
    model.n_cells cells at `diameter` (the parent scaled), m_min from the mean cell's mass."""
    from driver.bcm.particle import parent_shape  # noqa: PLC0415 (geometry; not needed to validate)

    m = cfg.model
    volume = parent_shape(m.shape, diameter, m.diameter_kind).volume
    m_min = BCM_MIN_MASS_RATIO * m.density * volume / m.n_cells
    k_max = max(m.contact.kn, m.interface.kn)
    return 2.0 * math.pi * math.sqrt(0.5 * m_min / k_max) / cfg.scenario.steps_per_period


def bcm_impact(cfg: RunConfig, ranks: int, max_time: float | None = None) -> SizeEstimate:
    """A BCM impact: the cells, interfaces and contact points of the tessellation, at most
    max_time / dt steps (max_time: the scenario's unless given)."""
    m, sc = cfg.model, cfg.scenario
    max_time = sc.max_time if max_time is None else max_time
    n = m.n_cells
    interfaces = bcm_interfaces(n)
    points = int(round(interfaces * BCM_POINTS_PER_INTERFACE))
    dt = bcm_timestep(cfg, m.diameter)
    return SizeEstimate(
        model="BCM", elements=n, element_name="cells", bonds=interfaces,
        bond_name=f"interfaces ({points:,} contact points)",
        memory_bytes=int(max(base + per_cell * n for base, per_cell in BCM_MEMORY_LINES) + _ranks_memory(ranks)),
        seconds_per_1000_steps=BCM_SECONDS_PER_CELL * n / ranks,
        steps=int(math.ceil(max_time / dt)), ranks=ranks)


def bcm_crush(cfg: RunConfig, ranks: int) -> SizeEstimate:
    """A BCM crush: the impact's particle, at most the time to the strain limit or max_time
    (the diameter standing for the height between the platens)."""
    sc = cfg.scenario
    return bcm_impact(cfg, ranks, min(sc.max_time, sc.max_strain * cfg.model.diameter / sc.platen_speed))


def bcm_compress(cfg: RunConfig, ranks: int) -> SizeEstimate:
    """A BCM bed in compression: n_grains x n_cells cells (grains of other sizes than
    model.diameter keep n_cells), and a guess of its length: the fill and the loading each
    over 1 % of the loose box's height (the unloading as the loading; the 30-grain example
    loads over 0.7 % of it), capped by max_time; the time step from the smallest grain's cells."""
    import numpy as np  # noqa: PLC0415

    from driver.assembly import grain_sizes  # noqa: PLC0415

    m, sc, a = cfg.model, cfg.scenario, cfg.model.assembly
    one = bcm_impact(cfg, 1, sc.max_time)
    n = a.n_grains * m.n_cells
    dt = bcm_timestep(cfg, float(grain_sizes(a.sizes, a.n_grains, np.random.default_rng(0)).min()))
    travel = 0.01 * a.box[2]
    t = travel / sc.fill_speed + travel / sc.platen_speed * (2.0 if sc.unload else 1.0) + sc.hold_time
    return SizeEstimate(
        model="BCM bed", elements=n, element_name=f"cells ({a.n_grains} grains of {m.n_cells})",
        bonds=one.bonds * a.n_grains,
        bond_name=f"interfaces ({int(round(one.bonds * BCM_POINTS_PER_INTERFACE)) * a.n_grains:,} contact points)",
        memory_bytes=int(max(base + per_cell * n for base, per_cell in BCM_MEMORY_LINES) + _ranks_memory(ranks)),
        seconds_per_1000_steps=BCM_SECONDS_PER_CELL * n / ranks, steps=int(math.ceil(min(sc.max_time, t) / dt)),
        ranks=ranks)


def bpm_size(cfg: RunConfig, ranks: int, steps: int, thickness: float | None = None) -> SizeEstimate:
    """A BPM run of `steps` steps: the packing's particles, bonds and angles (3D: an L x L x
    thickness slab when thickness is given)."""
    from driver.bpm.packing import particle_count  # noqa: PLC0415 (imports scipy)

    m = cfg.model
    d = m.dimension
    n = particle_count(d, m.L, m.packing_fraction, thickness, m.packing or "contact")
    bonds = int(round(BPM_BONDS_PER_PARTICLE[d] * n))
    angles = int(round(BPM_ANGLES_PER_PARTICLE[d] * n))
    return SizeEstimate(
        model=f"BPM {d}D", elements=n, element_name="particles", bonds=bonds + angles,
        bond_name=f"bonds + angles ({bonds:,} + {angles:,})",
        memory_bytes=int(BPM_MEMORY_BASE[d] + _ranks_memory(ranks) + BPM_MEMORY_PER_PARTICLE[d] * n),
        seconds_per_1000_steps=BPM_SECONDS_PER_PARTICLE[d] * n / ranks, steps=steps, ranks=ranks)


def bpm_shear(cfg: RunConfig, ranks: int) -> SizeEstimate:
    """A BPM shear run: max_strain / (rate dt) steps."""
    sc = cfg.scenario
    return bpm_size(cfg, ranks, steps_for_strain(sc.max_strain, sc.strain_rate, cfg.model.timestep))


#: the BPM bed's travel guesses, fractions of the loose box's height: the fill (the platen's travel to
#: the dense start) and the loading (measured on examples/bpm_bed_quick.yaml, 2026-12-03: the fill
#: 3.4 mm and the loading to 5 MPa about 0.6 mm of a 20 mm loose box)
BPM_BED_FILL_TRAVEL = 0.15
BPM_BED_LOAD_TRAVEL = 0.04


def bpm_compress(cfg: RunConfig, ranks: int, particles: int) -> SizeEstimate:
    """A BPM bed in compression: `particles` particles (the unit counts them from the grains'
    sizes), and a guess of its length: the fill over BPM_BED_FILL_TRAVEL of the loose box's
    height at fill_speed, the loading over BPM_BED_LOAD_TRAVEL at platen_speed (the unloading as
    the loading), capped by max_time; the time step from the walls' contact period
    (driver/bpm/bed.py)."""
    from driver.bpm.impact import lj_units, plane_law  # noqa: PLC0415

    m, sc, a = cfg.model, cfg.scenario, cfg.model.assembly
    un = lj_units(m.particle.units)
    dt = min(m.timestep, plane_law(m.particle.contact, un)["period"] / sc.steps_per_period) * un["tau"]
    t = (BPM_BED_FILL_TRAVEL * a.box[2] / sc.fill_speed + sc.hold_time
         + BPM_BED_LOAD_TRAVEL * a.box[2] / sc.platen_speed * (2.0 if sc.unload else 1.0))
    bonds = int(round(BPM_BONDS_PER_PARTICLE[3] * particles))
    angles = int(round(BPM_ANGLES_PER_PARTICLE[3] * particles))
    return SizeEstimate(
        model="BPM bed", elements=particles, element_name=f"particles ({a.n_grains} grains)", bonds=bonds + angles,
        bond_name=f"bonds + angles ({bonds:,} + {angles:,})",
        memory_bytes=int(BPM_MEMORY_BASE[3] + _ranks_memory(ranks) + BPM_MEMORY_PER_PARTICLE[3] * particles),
        seconds_per_1000_steps=BPM_SECONDS_PER_PARTICLE[3] * particles / ranks,
        steps=int(math.ceil(min(sc.max_time, t) / dt)), ranks=ranks)
