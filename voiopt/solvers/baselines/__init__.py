"""Baselines: shortest-path and greedy for one robot (heuristics), and the conflict-free walker for a fleet (fleet)."""
