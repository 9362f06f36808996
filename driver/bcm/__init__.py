"""Bonded cell method (BCM): parent shapes, Voronoi cell tessellation, interfaces and cell statistics."""
