"""The BCM step, before and after the optimisations of issue 27: a 300-cell impact's records and
break table against reference data made by the code before them (commit 5893c64, main when
issue 27's work began).

The run: the quick example's particle (300 cells, 4.5 m/s, G_c = 1 J/m^2, the model options
pinned below), from the driver's own setup input, for 3,000 steps in chunks of 500 (`run`
commands, as the driver's chunks: each starts with a setup force evaluation) with a record
every 50 steps of every energy and counter of the records at full precision (%.17g) and the
centre of mass and mean angular momentum; free flight (steps 0-200), contact and fracture
(200-2414, 1100 interfaces broken) and the start of the settled tail.

- `test_step_records_bit_identical`: every value of every record and every line of the break
  table equal, to the last bit. This holds for every change whose arithmetic is the same
  operations in the same order (issue 27: bookkeeping moved, memory layout, work skipped that
  no record reads).
- `test_step_records_within_roundoff`: for a change that is exact only to round-off
  (operations reordered): the first 600 steps (free flight and the first breaks, before
  round-off can grow through the fracture's instabilities) to 1e-9 relative, and the run's
  totals (broken interfaces within 2 %, energies within 5 % of the initial kinetic energy).
  Run with the exact test it is implied; kept for a change that gives up bit-identity.

Regenerate the reference (only from a tree whose results are the accepted ones):
    python tests/test_bcm_step_regression.py --write
"""

from __future__ import annotations

import gzip
import io
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

REFERENCE = Path(__file__).resolve().parent / "data" / "bcm_step_300"
STEPS, CHUNK, EVERY = 3000, 500, 50
# the record: name -> LAMMPS expression; every value at full precision
RECORD = {
    "step": "step", "ke": "c_ket", "ke_rot": "f_integrate", "ebond": "ebond", "pe": "pe",
    **{f"griffith{k}": f"f_BCM_GRIFFITH[{k}]" for k in range(1, 14)},
    **{f"plane{k}": f"f_plane[{k}]" for k in range(1, 9)},
    "contacts": "c_cpair", **{f"contacts{k}": f"c_cpair[{k}]" for k in range(1, 8)},
    "xcm": "xcm(all,x)", "ycm": "xcm(all,y)", "zcm": "xcm(all,z)",
    "vzcm": "vcm(all,z)", "omega_x": "c_om[1]", "omega_y": "c_om[2]", "omega_z": "c_om[3]",
}


def config(out: Path):
    from driver.config import parse_config  # noqa: PLC0415

    return parse_config({
        "name": "bcm_step_regression", "seed": 1,
        "model": {"kind": "bcm", "shape": "truncated_pentakis_dodecahedron", "diameter": 2.0e-3,
                  "diameter_kind": "circumscribed", "n_cells": 300, "density": 6000, "rounding": 0.02,
                  "interface": {"kn": 1.0e7, "kt": 0.8e7, "en2": 0.999, "G_c": 1.0},
                  "contact": {"kn": 1.0e8, "kt": 8.0e7, "en2": 0.001, "mu": 0.3},
                  "griffith_energy": "stored", "interface_stiffness": "per_interface",
                  "broken": {"stiffness": "contact", "damping": "interface", "shear_at_break": "carried",
                             "normal_at_break": "shifted"},
                  "plane": {"stiffness": "per_point"}},
        "scenario": {"kind": "impact", "velocity": 4.5, "steps_per_period": 50, "thermo_every": 10,
                     "max_time": 4.0e-4},
        "output": {"dir": str(out), "plots": False},
    })


def run_records(work: Path) -> tuple[pd.DataFrame, str]:
    """Build the system with the driver, run it, and return (records, break table text)."""
    from driver.bcm.impact import build_system, render_inputs  # noqa: PLC0415
    from driver.plugin_build import plugin_library  # noqa: PLC0415
    from driver.rundir import RunDir  # noqa: PLC0415
    from driver.runner import run_input  # noqa: PLC0415

    cfg = config(work / "run")
    rd = RunDir(cfg.run_dir())
    rd.prepare(force=True)
    system = build_system(cfg, rd)
    setup, _, _ = render_inputs(cfg, plugin_library(), system)
    values = " ".join(f"$({expr}:%.17g)" if name != "step" else "$(step)" for name, expr in RECORD.items())
    text = (setup.split("# Stop rule")[0]
            + "compute pom all property/atom omegax omegay omegaz\ncompute om all reduce ave c_pom[1] c_pom[2] c_pom[3]\n"
            + f'fix exact all print {EVERY} "{values}" file records.dat screen no title "# {" ".join(RECORD)}"\n'
            + f"run {CHUNK}\n" * (STEPS // CHUNK))
    (rd.root / "step_regression.lammps").write_text(text)
    run_input(rd.root, "step_regression.lammps")
    records = pd.read_csv(rd.root / "records.dat", sep=r"\s+", comment="#", names=list(RECORD), dtype=str)
    return records, (rd.root / "breaks.dat").read_text()


def load_reference() -> tuple[pd.DataFrame, str]:
    with gzip.open(REFERENCE / "records.dat.gz", "rt") as f:
        records = pd.read_csv(f, sep=r"\s+", comment="#", names=list(RECORD), dtype=str)
    with gzip.open(REFERENCE / "breaks.dat.gz", "rt") as f:
        breaks = f.read()
    return records, breaks


@pytest.fixture(scope="module")
def runs(tmp_path_factory, plugin_path):
    # the reference is part of the repository: its absence is a failure, not a skip
    assert (REFERENCE / "records.dat.gz").exists(), "no reference data (python tests/test_bcm_step_regression.py --write)"
    return run_records(tmp_path_factory.mktemp("step")), load_reference()


@pytest.fixture(scope="module")
def runs_without_avx(tmp_path_factory, plugin_path):
    """The same run with the styles' baseline loops (BRITTLE_NO_AVX=1, read when a style is
    created: the run is in this process)."""
    # the reference is part of the repository: its absence is a failure, not a skip
    assert (REFERENCE / "records.dat.gz").exists(), "no reference data (python tests/test_bcm_step_regression.py --write)"
    import os  # noqa: PLC0415

    before = os.environ.get("BRITTLE_NO_AVX")
    os.environ["BRITTLE_NO_AVX"] = "1"
    try:
        return run_records(tmp_path_factory.mktemp("step_no_avx")), load_reference()
    finally:
        if before is None:
            del os.environ["BRITTLE_NO_AVX"]
        else:
            os.environ["BRITTLE_NO_AVX"] = before


def test_step_records_bit_identical(runs):
    assert_bit_identical(runs)


def test_step_records_bit_identical_without_avx(runs_without_avx):
    """The baseline loops (bond kernel one point at a time, fix bcm/rigid's scalar batch) give
    the AVX loops' results to the last bit."""
    assert_bit_identical(runs_without_avx)


def assert_bit_identical(runs):
    (records, breaks), (ref, ref_breaks) = runs
    assert list(records.step) == list(ref.step)
    for name in RECORD:
        diff = records[name] != ref[name]
        assert not diff.any(), (f"{name} differs first at step {records.step[diff.idxmax()]}: "
                                f"{records[name][diff.idxmax()]} against {ref[name][diff.idxmax()]}")
    ours, theirs = breaks.splitlines(), ref_breaks.splitlines()
    assert len(ours) == len(theirs)
    for a, b in zip(ours, theirs):
        assert a == b


def test_step_records_within_roundoff(runs):
    (records, breaks), (ref, ref_breaks) = runs
    ours, theirs = records.astype(float), ref.astype(float)
    assert list(ours.step) == list(theirs.step)
    early = theirs.step <= 600
    for name in RECORD:
        a, b = ours[name][early].to_numpy(), theirs[name][early].to_numpy()
        scale = np.maximum(np.abs(b), 1e-30)
        # an energy of a few ulps of the kinetic energy may be noise: judged against it
        if name not in ("step", "xcm", "ycm", "zcm", "vzcm") and not name.startswith(("griffith1", "griffith2")):
            scale = np.maximum(scale, 1e-12 * theirs.ke[early].to_numpy())
        np.testing.assert_array_less(np.abs(a - b) / scale, 1e-9, err_msg=name)
    last_o, last_t = ours.iloc[-1], theirs.iloc[-1]
    assert abs(last_o.griffith2 - last_t.griffith2) <= 0.02 * last_t.griffith2
    ke0 = theirs.ke.iloc[0]
    for name in ("ke", "griffith4", "griffith6", "griffith7", "plane3", "contacts4"):
        assert abs(last_o[name] - last_t[name]) <= 0.05 * ke0, name
    assert abs(len(breaks.splitlines()) - len(ref_breaks.splitlines())) <= 0.02 * len(ref_breaks.splitlines())


if __name__ == "__main__":
    import tempfile  # noqa: PLC0415

    if sys.argv[1:] != ["--write"]:
        sys.exit(__doc__)
    with tempfile.TemporaryDirectory() as tmp:
        records, breaks = run_records(Path(tmp))
    REFERENCE.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    buf.write("# " + " ".join(RECORD) + "\n")
    records.to_csv(buf, sep=" ", header=False, index=False)
    with gzip.GzipFile(REFERENCE / "records.dat.gz", "wb", mtime=0) as f:
        f.write(buf.getvalue().encode())
    with gzip.GzipFile(REFERENCE / "breaks.dat.gz", "wb", mtime=0) as f:
        f.write(breaks.encode())
    print(f"{len(records)} records, {len(breaks.splitlines()) - 1} breaks written to {REFERENCE}")
