"""Clemmer-Robbins bonded particle model (BPM): packing, bond network and LAMMPS data file."""
