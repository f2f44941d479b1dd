"""planner/io."""
