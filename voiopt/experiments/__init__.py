"""Experiments: sweeps of many runs (runner), gap reports (gaps), the paper's figures (paper)
and the demo. They call solvers through the registry and never compute a value themselves."""
