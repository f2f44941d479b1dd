"""planner/identify."""
