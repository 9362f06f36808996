"""Analysis of run outputs: dump readers, grain graphs, statistics, plots.

`driver run` calls these functions at its end and `driver post` calls the same ones on
dumps, so the two never disagree.
"""
