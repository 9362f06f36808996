"""pair_style cr/repulsion against SPEC 2.2 Eq. 1 and 5 and against the native styles it
replaces (hybrid/overlay lj/cut, sigma = abar 2^(-1/6), shifted, + dpd/tstat at T = 0).

The native comparison runs both on one random configuration of two particle sizes, with
random velocities, bonded chains and a special_bonds factor strictly between 0 and 1, so
that exclusion, scaling, mixing, damping and every tally path are compared.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

from driver.bpm.datafile import write_references
from driver.engine import Lammps, LammpsError

GAMMA = 50.0
DIAMETERS = {1: 1.0, 2: 0.6}
U = {1: 1.0, 2: 0.7}
GAMMAS = {1: GAMMA, 2: 30.0}
CELLS, SPACING = 5, 0.8


# ---------------------------------------------------------------- SPEC expectations

def f_nonbonded(r, abar=1.0, u=1.0):
    """SPEC 2.2 Eq. 1, positive = repulsive."""
    return 12 * u / r * ((abar / r) ** 12 - (abar / r) ** 6) if r < abar else 0.0


def e_nonbonded(r, abar=1.0, u=1.0):
    """WCA energy, the integral of Eq. 1 from r to abar."""
    return u * ((abar / r) ** 12 - 2 * (abar / r) ** 6 + 1) if r < abar else 0.0


def mixed(ti, tj):
    """abar arithmetic (sum of radii), u and gamma geometric."""
    return (0.5 * (DIAMETERS[ti] + DIAMETERS[tj]), float(np.sqrt(U[ti] * U[tj])),
            float(np.sqrt(GAMMAS[ti] * GAMMAS[tj])))


# ---------------------------------------------------------------- configuration

def configuration(seed=4):
    """Jittered cubic lattice in a periodic box: positions, types, velocities, bonds (rows of
    four atoms along x, 1-based tags) and the box length."""
    rng = np.random.default_rng(seed)
    idx = np.array([(i, j, k) for i in range(CELLS) for j in range(CELLS) for k in range(CELLS)])
    x = (idx + 0.5) * SPACING + rng.uniform(-0.06, 0.06, size=idx.shape)
    types = rng.choice([1, 2], size=len(x), p=[0.6, 0.4])
    v = rng.normal(scale=0.7, size=x.shape)
    tag = {tuple(p): n + 1 for n, p in enumerate(idx)}
    bonds = [(tag[(i, j, k)], tag[(i + 1, j, k)])
             for j in range(0, CELLS, 2) for k in range(0, CELLS, 2) for i in range(CELLS - 2)]
    return x, types, v, bonds, CELLS * SPACING


def write_data(path, x, types, v, bonds, length):
    lines = ["cr/repulsion test", "", f"{len(x)} atoms", f"{len(bonds)} bonds", "2 atom types",
             "1 bond types", "", f"0 {length!r} xlo xhi", f"0 {length!r} ylo yhi",
             f"0 {length!r} zlo zhi", "", "Masses", "", "1 1.0", "2 1.0", "", "Atoms # bond", ""]
    lines += [f"{n + 1} 1 {int(t)} {p[0]!r} {p[1]!r} {p[2]!r}" for n, (t, p) in enumerate(zip(types, x.tolist()))]
    lines += ["", "Velocities", ""]
    lines += [f"{n + 1} {q[0]!r} {q[1]!r} {q[2]!r}" for n, q in enumerate(v.tolist())]
    if bonds:
        lines += ["", "Bonds", ""]
        lines += [f"{n + 1} 1 {a} {b}" for n, (a, b) in enumerate(bonds)]
    path.write_text("\n".join(lines) + "\n")


SETUP = """
units lj
atom_style bond
boundary p p p
newton {newton}
special_bonds lj 0.0 0.5 1.0 coul 1 1 1
read_data {data}
comm_modify vel yes
neighbor 0.3 bin
bond_style zero
bond_coeff *
{pair}
compute vir all pressure NULL virial
compute pea all pe/atom pair
compute sa all stress/atom NULL virial
thermo_style custom step pe epair
thermo_modify norm no
run 0
"""


def cr_pair(explicit_mixed: bool) -> str:
    lines = ["pair_style cr/repulsion"]
    for t in (1, 2):
        lines.append(f"pair_coeff {t} {t} {U[t]!r} {DIAMETERS[t]!r} {GAMMAS[t]!r}")
    if explicit_mixed:
        abar, u, g = mixed(1, 2)
        lines.append(f"pair_coeff 1 2 {u!r} {abar!r} {g!r}")
    return "\n".join(lines)


def native_pair() -> str:
    lines = ["pair_style hybrid/overlay lj/cut 1.0 dpd/tstat 0.0 0.0 1.0 8923"]
    for ti, tj in ((1, 1), (1, 2), (2, 2)):
        abar, u, g = (DIAMETERS[ti], U[ti], GAMMAS[ti]) if ti == tj else mixed(ti, tj)
        lines.append(f"pair_coeff {ti} {tj} lj/cut {u!r} {abar * 2 ** (-1 / 6)!r} {abar!r}")
        lines.append(f"pair_coeff {ti} {tj} dpd/tstat {g!r} {abar!r}")
    lines.append("pair_modify pair lj/cut shift yes")
    return "\n".join(lines)


def by_tag(lmp, values):
    nlocal = lmp.extract_global("nlocal")
    ids = np.array(lmp.numpy.extract_atom("id")[:nlocal])
    return np.array(values[:nlocal])[np.argsort(ids)]


def observe(lmp):
    """Pair energy, per-atom forces, pair energies and virials (by tag), global virial."""
    return {
        "epair": lmp.get_thermo("epair"),
        "f": by_tag(lmp, lmp.numpy.extract_atom("f")),
        "pe_atom": by_tag(lmp, lmp.numpy.extract_compute("pea", 1, 1)),
        "virial_atom": by_tag(lmp, lmp.numpy.extract_compute("sa", 1, 2)),
        "virial": np.array(lmp.numpy.extract_compute("vir", 0, 1)),
    }


def run_system(plugin_path, data, pair, newton="on"):
    lmp = Lammps()
    try:
        lmp.command(f"plugin load {plugin_path}")
        lmp.commands(SETUP.format(newton=newton, data=data, pair=pair))
        return observe(lmp)
    finally:
        lmp.close()


@pytest.fixture(scope="module")
def data_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("pair") / "system.data"
    write_data(path, *configuration())
    return path


# ---------------------------------------------------------------- against the native styles

@pytest.mark.parametrize("newton", ["on", "off"])
@pytest.mark.parametrize("explicit_mixed", [True, False])
def test_equals_native_lj_cut_plus_dpd_tstat(plugin_path, data_file, newton, explicit_mixed):
    ours = run_system(plugin_path, data_file, cr_pair(explicit_mixed), newton)
    native = run_system(plugin_path, data_file, native_pair(), newton)

    # the configuration exercises what it should: repulsion, damping, scaled 1-3 pairs
    assert ours["epair"] > 1.0
    assert np.abs(ours["f"]).max() > 10.0

    for key in ("f", "pe_atom", "virial_atom", "virial"):
        scale = np.abs(native[key]).max()
        np.testing.assert_allclose(ours[key], native[key], rtol=1e-12, atol=1e-12 * scale,
                                   err_msg=key)
    assert ours["epair"] == pytest.approx(native["epair"], rel=1e-12)


def test_special_factor_scales_and_zero_excludes(plugin_path, data_file):
    """Bonded (1-2, factor 0) pairs give nothing, 1-3 pairs (factor 0.5) half: compared
    with the same system without bonds, where every pair counts fully."""
    x, types, v, bonds, length = configuration()
    free = data_file.parent / "free.data"
    write_data(free, x, types, v, [], length)
    with_bonds = run_system(plugin_path, data_file, cr_pair(True))
    without = run_system(plugin_path, free, cr_pair(True))
    assert with_bonds["epair"] < without["epair"]

    # expected energy from SPEC Eq. 1 pair by pair, with the special factors
    bonded = {frozenset(b) for b in bonds}
    neighbours = {}
    for a, b in bonds:
        neighbours.setdefault(a, set()).add(b)
        neighbours.setdefault(b, set()).add(a)
    second = {frozenset((a, c)) for b, ns in neighbours.items() for a in ns for c in ns if a != c}
    expected = 0.0
    for i in range(len(x)):
        for j in range(i + 1, len(x)):
            d = x[i] - x[j]
            d -= length * np.round(d / length)
            r = np.linalg.norm(d)
            abar, u, _ = mixed(types[i], types[j])
            pair = frozenset((i + 1, j + 1))
            factor = 0.0 if pair in bonded else 0.5 if pair in second else 1.0
            expected += factor * e_nonbonded(r, abar, u)
    assert with_bonds["epair"] == pytest.approx(expected, rel=1e-12)


# ---------------------------------------------------------------- force law

TWO = """
units lj
atom_style angle
boundary f f f
newton on off
comm_modify vel yes
special_bonds lj 0 1 1 coul 1 1 1
region box block -5 5 -5 5 -5 5
create_box 1 box bond/types 1 extra/bond/per/atom 4 angle/types 1 extra/angle/per/atom 6 &
    extra/special/per/atom 10
create_atoms 1 single {p1[0]} {p1[1]} {p1[2]}
create_atoms 1 single {p2[0]} {p2[1]} {p2[2]}
mass 1 1.0
pair_style cr/repulsion
pair_coeff 1 1 {u} {abar} {gamma}
{bond}
thermo_style custom step pe ebond epair
thermo_modify norm no
"""

BOND = """
bond_style breakable/cr
bond_coeff 1 1.05 0.0
create_bonds single/bond 1 1 2
"""

DIRECTION = np.array([0.48, 0.6, 0.64])
ORIGIN = np.array([-0.3, 0.2, 0.1])


def give_references(lmp, positions, bonds, angles=()):
    """fix breakable/references with the reference geometry (SPEC 2.2) of `positions`: the
    styles take r0 and theta0 from the input only. The file is read when the fix is defined."""
    with tempfile.TemporaryDirectory() as folder:
        path = write_references(Path(folder) / "system.refs", positions, bonds, angles)
        lmp.command(f"fix references all breakable/references {path}")


def make_two(lmp, r=0.9, u=1.3, abar=1.1, gamma=GAMMA, bond=False):
    p1, p2 = ORIGIN, ORIGIN + r * DIRECTION
    lmp.commands(TWO.format(p1=p1.tolist(), p2=p2.tolist(), u=u, abar=abar, gamma=gamma,
                            bond=BOND if bond else ""))
    if bond:
        give_references(lmp, np.array([p1, p2]), [(0, 1)])
    lmp.command("run 0")


def place(lmp, r, v1=(0, 0, 0), v2=(0, 0, 0)):
    p1, p2 = [float(c) for c in ORIGIN], [float(c) for c in ORIGIN + r * DIRECTION]
    v1, v2 = [float(c) for c in v1], [float(c) for c in v2]
    lmp.command(f"set atom 1 x {p1[0]!r} y {p1[1]!r} z {p1[2]!r} vx {v1[0]!r} vy {v1[1]!r} vz {v1[2]!r}")
    lmp.command(f"set atom 2 x {p2[0]!r} y {p2[1]!r} z {p2[2]!r} vx {v2[0]!r} vy {v2[1]!r} vz {v2[2]!r}")
    lmp.command("run 0")
    return lmp.get_thermo("epair"), by_tag(lmp, lmp.numpy.extract_atom("f"))


@pytest.mark.parametrize("ratio", [0.85, 0.93, 0.99, 1.01])
def test_force_and_energy_follow_eq1(lmp, ratio):
    u, abar = 1.3, 1.1
    make_two(lmp, u=u, abar=abar)
    r = ratio * abar
    e, f = place(lmp, r)
    assert e == pytest.approx(e_nonbonded(r, abar, u), rel=1e-12, abs=1e-14)
    np.testing.assert_allclose(f[1], f_nonbonded(r, abar, u) * DIRECTION, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(f[0], -f[1], rtol=0, atol=1e-13)


def test_forces_are_minus_gradient_of_energy(plugin_path, data_file, tmp_path):
    """Many pairs at once, velocities zero: each force component against a central
    difference of the total pair energy."""
    x, types, _, bonds, length = configuration()
    still = tmp_path / "still.data"
    write_data(still, x, types, np.zeros_like(x), bonds, length)
    lmp = Lammps()
    try:
        lmp.command(f"plugin load {plugin_path}")
        lmp.commands(SETUP.format(newton="on", data=still, pair=cr_pair(False)))
        f = by_tag(lmp, lmp.numpy.extract_atom("f"))
        scale = np.abs(f).max()
        rng = np.random.default_rng(2)
        h = 1e-6
        for tag in rng.choice(len(x), size=6, replace=False) + 1:
            p = x[tag - 1]
            for axis, name in enumerate("xyz"):
                energies = []
                for sign in (1, -1):
                    q = p.copy()
                    q[axis] += sign * h
                    lmp.command(f"set atom {tag} {name} {float(q[axis])!r}")
                    lmp.command("run 0")
                    energies.append(lmp.get_thermo("epair"))
                lmp.command(f"set atom {tag} {name} {float(p[axis])!r}")
                fd = -(energies[0] - energies[1]) / (2 * h)
                assert f[tag - 1, axis] == pytest.approx(fd, abs=1e-6 * scale)
    finally:
        lmp.close()


def test_damping_follows_eq5(lmp):
    u, abar = 1.3, 1.1
    make_two(lmp, u=u, abar=abar)
    r = 0.95 * abar
    v1, v2 = np.array([0.3, 0.2, 0.0]), np.array([-0.1, 0.5, 0.1])
    e_damped, f = place(lmp, r, v1, v2)
    e_static, _ = place(lmp, r)
    assert e_damped == pytest.approx(e_static, rel=1e-14)  # damping is not in the energy
    rhat = -DIRECTION  # from atom 2 to atom 1
    expected = f_nonbonded(r, abar, u) * rhat - GAMMA * (1 - r / abar) ** 2 * (rhat @ (v1 - v2)) * rhat
    np.testing.assert_allclose(f[0], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(f[1], -f[0], rtol=0, atol=1e-12)

    _, f = place(lmp, 1.001 * abar, v1, v2)  # nothing beyond abar, damping included
    assert np.abs(f).max() == 0.0


def test_single_through_compute_pair_local(lmp):
    u, abar = 1.3, 1.1
    make_two(lmp, u=u, abar=abar)
    lmp.command("compute pl all pair/local dist eng force")
    r = 0.92 * abar
    v1, v2 = np.array([0.3, 0.2, 0.0]), np.array([-0.1, 0.5, 0.1])
    place(lmp, r, v1, v2)
    dist, eng, force = lmp.numpy.extract_compute("pl", 2, 2)[0]
    rhat = -DIRECTION
    assert dist == pytest.approx(r, rel=1e-12)
    assert eng == pytest.approx(e_nonbonded(r, abar, u), rel=1e-12)
    damping = -GAMMA * (1 - r / abar) ** 2 * (rhat @ (v1 - v2))
    assert force == pytest.approx(f_nonbonded(r, abar, u) + damping, rel=1e-12)



def test_single_reports_the_damping_power(lmp):
    """single()'s extra value (compute pair/local p1): the power the damping of Eq. 5
    dissipates, gamma w^2 (rhat . (v_i - v_j))^2, w = 1 - r / abar; zero beyond abar."""
    u, abar = 1.3, 1.1
    make_two(lmp, u=u, abar=abar)
    lmp.command("compute pl all pair/local p1")
    v1, v2 = np.array([0.3, 0.2, 0.0]), np.array([-0.1, 0.5, 0.1])
    r = 0.92 * abar
    place(lmp, r, v1, v2)
    power = lmp.numpy.extract_compute("pl", 2, 1)[0]
    assert power == pytest.approx(GAMMA * (1 - r / abar) ** 2 * (DIRECTION @ (v1 - v2)) ** 2, rel=1e-12)


# ---------------------------------------------------------------- bonded pairs and breaks

def test_bonded_pair_excluded_until_its_bond_breaks(lmp):
    r0, abar = 1.1, 1.0
    make_two(lmp, r=r0, u=1.0, abar=abar, gamma=0.0, bond=True)
    r = 0.9
    e, _ = place(lmp, r)
    assert e == 0.0
    assert lmp.get_thermo("ebond") > 0.0

    place(lmp, 1.05 * r0 * 1.001)  # breaks
    assert lmp.extract_fix("BREAKABLE_SPECIAL", 0, 1, 0) == 1

    e, f = place(lmp, r)
    assert lmp.get_thermo("ebond") == 0.0
    assert e == pytest.approx(e_nonbonded(r, abar), rel=1e-12)
    np.testing.assert_allclose(f[1] @ DIRECTION, f_nonbonded(r, abar), rtol=1e-12)


# ---------------------------------------------------------------- prerequisites and input

def test_init_style_requires_ghost_velocities(lmp):
    make_two(lmp)
    lmp.command("comm_modify vel no")
    with pytest.raises(LammpsError, match="comm_modify vel yes"):
        lmp.command("run 0")


@pytest.mark.parametrize("args,message", [
    ("1 1 1.0 1.0", "pair_coeff I J u abar gamma"),
    ("1 1 -1 1.0 50", "u must be >= 0"),
    ("1 1 1.0 0 50", "abar must be > 0"),
    ("1 1 1.0 1.0 -2", "gamma must be >= 0"),
])
def test_coeff_rejects_bad_input(lmp, args, message):
    make_two(lmp)
    with pytest.raises(LammpsError, match=message):
        lmp.command(f"pair_coeff {args}")


def test_style_takes_no_arguments(lmp):
    make_two(lmp)
    with pytest.raises(LammpsError, match="takes no arguments"):
        lmp.command("pair_style cr/repulsion 1.0")
