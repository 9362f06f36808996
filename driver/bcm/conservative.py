"""The LAMMPS setup of a BCM particle with every loss switched off (e_n^2 = 1 for interfaces
and contacts, mu = 0, G_c = 1e12 J/m^2: nothing damps, slides or breaks), for energy
conservation checks: the time-step study (bench/timestep_study.py) and the tests
(tests/test_bcm_impact.py, tests/test_bcm_timestep.py). Format keys: dir (the folder of
system.data, cells.txt, interfaces.txt), cutoff, rm, kn_c, kt_c, kn, kt, skin, dt. It defines
ket (translational kinetic energy); f_integrate adds the rotational part."""

CONSERVATIVE_SETUP = """
units           si
dimension       3
boundary        m m m
atom_style      hybrid bond sphere
atom_modify     map array
newton          on off
special_bonds   lj 0 1 1 coul 1 1 1
fix             cellprops all property/atom d2_bcm_quat 4 d2_bcm_inertia 3 d2_bcm_angmom 3 ghost yes
read_data       {dir}/system.data fix cellprops NULL BcmProps
comm_modify     vel yes cutoff {cutoff!r}
pair_style      bcm/contact cells {dir}/cells.txt rm {rm!r}
pair_coeff      * * {kn_c!r} {kt_c!r} 1.0 0.0
bond_style      bcm/griffith geometry {dir}/interfaces.txt
bond_coeff      1 {kn!r} {kt!r} 1.0 1e12 {kn_c!r} {kt_c!r} 1.0 0.0
neighbor        {skin!r} bin
neigh_modify    delay 0 every 1 check yes
timestep        {dt!r}
fix             integrate all bcm/rigid
compute         ket all ke
compute         cpair all pair bcm/contact
"""
