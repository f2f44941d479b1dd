"""planner/physics."""
