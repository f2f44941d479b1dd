"""Test tooling that the planner's runtime never imports.

* :mod:`testkit.flight` — a mission flown by the project's own models, as a flight record
  (simulated flights with known true parameters);
* :mod:`testkit.writers` — flight record → DataFlash ``.bin``, MAVLink ``.tlog`` and PX4
  ``.ulg`` files.

Used by the tests (``tests/conftest.py`` puts the repository root on ``sys.path``) and by
``logs/make_examples.py``. Data made here by the project's own models never counts as
validation of those models.
"""
