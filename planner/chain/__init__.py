"""planner/chain."""
