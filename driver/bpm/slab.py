"""The sample of a BPM fracture test (SPEC 2.3) before it is cut: the run's periodic solid in
2D, and in 3D a thin slab L x L x T, periodic in x, y and z ("3D: a thin periodic third
dimension"), with its Delaunay network (SPEC 2.1).

The slab is a packing of its own (driver/bpm/packing.py, `thickness` T; cached like the cubes),
not a cut of the cubic packing: relaxed in its periodic slab box, it has no surface in z and
its bonds through the z faces are those of the bulk. A test then cuts it free in x and y and
keeps z periodic (driver/bpm/mode1.py; a mode-II test keeps all three directions periodic).

T >= MIN_THICKNESS: the periodic network needs every box edge at least 4 diameters long
(driver/bpm/network.py, MIN_BOX_DIAMETERS) so that minimum images are unambiguous.
"""

from __future__ import annotations

from driver.bpm.network import MIN_BOX_DIAMETERS, Network, delaunay_network
from driver.bpm.packing import DIAMETER_3D, Packing, cached_packing
from driver.bpm.solid import packing_and_network
from driver.cache import cache_base

#: Thinnest slab, in a: the network's shortest box edge (3D diameters are all a).
MIN_THICKNESS = MIN_BOX_DIAMETERS * DIAMETER_3D


def periodic_slab(cfg, thickness: float) -> tuple[Packing, Network]:
    """The periodic L x L x thickness packing of a 3D run's model (its seed, packing fraction,
    preparation model.packing and bond cut) and its network. Raises ValueError in 2D or below
    MIN_THICKNESS."""
    m = cfg.model
    if m.dimension != 3:
        raise ValueError("a periodic slab is a 3D sample")
    if thickness < MIN_THICKNESS:
        raise ValueError(f"slab thickness {thickness:g} below {MIN_THICKNESS:g} a: minimum images are ambiguous")
    packing = cached_packing(cache_base() / "packings", 3, m.L, cfg.seed, m.packing_fraction,
                             m.packing or "contact", thickness)
    return packing, delaunay_network(packing, m.bond_max_length)


def fracture_sample(cfg, thickness: float | None) -> tuple[Packing, Network]:
    """The periodic solid a fracture test cuts its sample from: the run's packing and network in
    2D (driver/bpm/solid.py), the slab of `thickness` in 3D."""
    if cfg.model.dimension == 2:
        return packing_and_network(cfg)
    return periodic_slab(cfg, float(thickness))
