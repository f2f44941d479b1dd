"""planner/io/logs/maps."""
