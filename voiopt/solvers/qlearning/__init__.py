"""The paper's Algorithm 1 (tabular Q-learning), compiled with numba, and its greedy rollout.

- _rng: splitmix64, the random numbers (the same stream as the plain-Python reference);
- _qtable: the Q-table, a hash table keyed by the packed state of models/mdp.py;
- _kernels: training episodes and the greedy rollout, compiled;
- solver: options, the training loop with progress and the stop rule, the result;
- reference: Algorithm 1 in plain Python, which the kernels reproduce bit for bit.
- _fleet: the same for several robots (MODEL.md section 10), over the joint state and action of
  models/fleet_mdp.py; reference.reference_fleet_qlearning is its plain-Python statement.
"""

from voiopt.solvers.qlearning.kernels import rollout, train
from voiopt.solvers.qlearning.rng import seed_state
from voiopt.solvers.qlearning.solver import BETA, EPISODES, GAMMA, solve, solve_aoi, warm_up
from voiopt.solvers.qlearning.table import QTable

__all__ = ["BETA", "EPISODES", "GAMMA", "QTable", "rollout", "seed_state", "solve", "solve_aoi", "train", "warm_up"]
