"""Sub-commands of the ``endurance`` CLI, one module per area."""
