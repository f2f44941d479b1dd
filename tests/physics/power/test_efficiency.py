"""The efficiency-against-load curve (planner.physics.power.efficiency)."""

import numpy as np
import pytest

from planner.physics.power.efficiency import load_dependent_battery_power


def test_a_copper_loss_motor_is_reproduced_exactly():
    """A pure copper loss at a fixed voltage (Drela's first-order motor): input power
    M + R I² with I = M/V, so 1/η = 1 + (R/V²) M is linear in M and the curve, set from
    η and its slope at a reference, gives that input power at every load."""
    r_ohm, v = 0.05, 22.2
    k = r_ohm / v**2
    m_ref, p_s = 200.0, 10.0
    eta0 = 1.0 / (1.0 + k * m_ref)
    eta1 = -k * m_ref * eta0**2              # dη/d(M/M_ref) at the reference
    m = np.array([50.0, 200.0, 400.0, 800.0])
    constant = m / eta0 + p_s                # the constant-efficiency model's power
    power = load_dependent_battery_power(constant, eta0, p_s, eta1, m_ref)
    assert power == pytest.approx(m + k * m**2 + p_s, rel=1e-12)


def test_at_the_reference_power_it_is_the_constant_efficiency_model():
    p = load_dependent_battery_power(200.0 / 0.7 + 5.0, 0.7, 5.0, -0.2, 200.0)
    assert float(p) == pytest.approx(200.0 / 0.7 + 5.0)


def test_the_efficiency_never_exceeds_one():
    """A rising efficiency extrapolated far above the reference would pass 1: held at 1,
    the battery power is the mechanical power plus the system load."""
    mech = 2000.0
    p = load_dependent_battery_power(mech / 0.8 + 5.0, 0.8, 5.0, 0.5, 100.0)
    assert float(p) == pytest.approx(mech + 5.0)
