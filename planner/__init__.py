"""UAV mission endurance planner: flight physics, battery models, log replay."""

__version__ = "0.1.0"
