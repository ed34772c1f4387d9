"""Policies under lossy links (MODEL.md section 11): the exact optimal policy, re-planning, saved policies, and the bounds on the optimal policy's value."""
