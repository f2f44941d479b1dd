"""planner/cli/plots."""
