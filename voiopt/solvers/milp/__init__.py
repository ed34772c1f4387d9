"""The exact time-expanded MILP on HiGHS (docs/milp.md).

- solver: the method (``solve``), its bisection for the bottleneck objectives and its stop rule;
- formulation: the rows and columns (``build`` for one objective, ``build_covering`` for a
  threshold of the bisection), in terms of the upload levels of ``uploads``;
- model: the arrays of one MILP, names, and a plan as a column vector;
- fleet: the paths of several robots (MODEL.md section 10) beside the one-robot path rows;
  fleet_start: a fleet's first plan;
- solution: a plan read off a solution; solution_file: other solvers' solution files;
- export: MPS or LP files; pyomo: the same model for Pyomo users.
"""
