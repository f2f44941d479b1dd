"""planner/cli."""
