"""The model's core: the instance, plans and policies, the simulator, results, physics, lossy links."""
