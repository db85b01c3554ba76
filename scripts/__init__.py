"""Developer scripts; a package so the architecture test can use import_graph's graph code."""
