"""The run's periodic BPM solid (SPEC 2.1): its packing (cached), its Delaunay network, and the
data file of the whole solid with its facts. The shear and moduli runs use it as it is; the
2D fracture tests cut their sample out of it (driver/bpm/slab.py)."""

from __future__ import annotations

import time

import numpy as np

from driver.bpm.datafile import write_data
from driver.bpm.network import Network, delaunay_network
from driver.bpm.packing import Packing, cached_packing
from driver.cache import cache_base


def packing_and_network(cfg) -> tuple[Packing, Network]:
    """The run's packing (cached) and its Delaunay network (SPEC 2.1)."""
    m = cfg.model
    packing = cached_packing(cache_base() / "packings", m.dimension, m.L, cfg.seed, m.packing_fraction,
                             m.packing or "contact")
    return packing, delaunay_network(packing, m.bond_max_length if m.dimension == 3 else None)


def build_system(cfg, rd) -> dict:
    """Packing -> Delaunay network -> data file; returns the network facts for the summary."""
    t0 = time.perf_counter()
    packing, net = packing_and_network(cfg)
    write_data(rd.root / "system.data", packing, net)
    return {
        "n_particles": int(len(packing.radii)),
        "n_bonds": int(len(net.bonds)),
        "n_angles": int(len(net.angles)),
        "bonds_per_particle": float(net.bonds_per_particle),
        "angles_per_particle": float(net.angles_per_particle),
        "max_r0": float(np.max(net.r0)),
        "mean_diameter": float(np.mean(2 * packing.radii)),
        "type_diameters": packing.type_diameters(),
        "build_seconds": time.perf_counter() - t0,
    }
