"""The time-expanded MILP (docs/milp.md), assembled as numpy/scipy arrays.

- formulation: the rows and columns (``build`` for one objective, ``build_covering`` for a
  threshold of the bisection), in terms of the upload levels of models/uploads.py;
- model: the arrays of one MILP, names, and a plan as a column vector;
- fleet: the paths of several robots (MODEL.md section 10) beside the one-robot path rows;
- solution: a plan read off a solution;
- export: MPS or LP files (min-voi in log-worths: log_worth);
- cvxpy_model: the same model as a cvxpy.Problem (the [cvxpy] extra, imported on use).
"""

from voiopt.models.milp.cvxpy_model import cvxpy_problem
from voiopt.models.milp.export import EXPORT_FORMATS, export, export_model
from voiopt.models.milp.formulation import (
    LevelTerms,
    build,
    build_covering,
    default_scale,
    level_terms,
)
from voiopt.models.milp.model import Model, new_highs
from voiopt.models.uploads import SCORE_RTOL, Structure, structure

__all__ = [
    "EXPORT_FORMATS", "SCORE_RTOL", "LevelTerms", "Model", "Structure", "build", "build_covering",
    "cvxpy_problem", "default_scale", "export", "export_model", "level_terms", "new_highs", "structure",
]
