"""The label-setting engine that dp, the beam planner and the fleet walker search with: numba
kernels (kernels, bounds; fleet_kernels for two robots), the tables every pass shares
(tables), one forward pass of one robot (search) and the search over two robots' product
state (fleet_search)."""
