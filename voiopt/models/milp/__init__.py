"""The time-expanded MILP (docs/milp.md), assembled as numpy/scipy arrays.

- formulation: the rows and columns (``build`` for one objective, ``build_covering`` for a
  threshold of the bisection), in terms of the upload levels of models/uploads.py;
- model: the arrays of one MILP, names, and a plan as a column vector;
- fleet: the paths of several robots (MODEL.md section 10) beside the one-robot path rows;
- solution: a plan read off a solution;
- export: MPS or LP files.
"""

from voiopt.models.milp.export import EXPORT_FORMATS, export
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
    "default_scale", "export", "level_terms", "new_highs", "structure",
]
