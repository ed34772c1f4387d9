"""The MDP of MODEL.md section 7, shared by Q-learning and the environments: one robot (robot) and a fleet's joint state and action (fleet)."""
