"""Networks to solve: the paper's random generator (generate) and the field presets: obstacles, docks, budgets and the factory floor (fields)."""
