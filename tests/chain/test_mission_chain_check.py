"""The pre-flight check chain: leg kinematics, power, charge, reserves, verdict."""

from pathlib import Path

import numpy as np
import pytest

from planner.physics.battery.elements import loaded_current
from planner.chain.mission_chain import MissionChain
from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import load_aircraft_and_battery

REPO = Path(__file__).resolve().parents[2]
SEA_LEVEL_20C = Environment(temperature_c=20.0)  # ρ = 1.204 kg/m³, the seed's condition


def chain(name="quad_7in.yaml", **kw):
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft" / name)
    return MissionChain(aircraft, pack, **kw)


def out_and_back(distance, speed=None, alt=30.0, hold=0.0, course=90.0):
    a = np.radians(course)
    far = (distance * np.sin(a), distance * np.cos(a))
    legs = [Leg("climb", start_alt_m=0, end_alt_m=alt, origin="climb"),
            Leg("cruise", (0, 0), far, alt, alt, speed_ms=speed, origin="out"),
            Leg("hover", far, far, alt, alt, duration_s=hold, origin="hold"),
            Leg("cruise", far, (0, 0), alt, alt, speed_ms=speed, origin="back"),
            Leg("descend", start_alt_m=alt, end_alt_m=0, origin="land")]
    return Mission("out and back", legs, SEA_LEVEL_20C)


def test_seed_hover_and_vertical_powers_through_the_chain():
    """Seed paper, 7-inch quad at ρ = 1.204 kg/m³: 75.2 W hover, 102.4 W climbing at
    3 m/s, 129.5 W at 6 m/s, 48.0 W descending at 3 m/s (each within 1.5 %)."""
    legs = [Leg("hover", duration_s=60, origin="hover"),
            Leg("climb", start_alt_m=0, end_alt_m=30, climb_rate_ms=3, origin="c3"),
            Leg("climb", start_alt_m=30, end_alt_m=90, climb_rate_ms=6, origin="c6"),
            Leg("descend", start_alt_m=90, end_alt_m=60, climb_rate_ms=3, origin="d3")]
    r = chain().check(Mission("seed", legs, SEA_LEVEL_20C))
    assert r.takeoff_mass_kg == pytest.approx(0.6)
    assert r.legs["power_w"].tolist() == pytest.approx([75.2, 102.4, 129.5, 48.0], rel=0.015)


def test_climb_power_difference_is_m_g_climb_over_eta():
    c = chain()
    legs = [Leg("hover", duration_s=10), Leg("climb", end_alt_m=20, climb_rate_ms=2.0)]
    r = c.check(Mission("m", legs, SEA_LEVEL_20C))
    dp = r.legs["power_w"][1] - r.legs["power_w"][0]
    assert dp == pytest.approx(0.6 * 9.80665 * 2.0 / 0.65, rel=0.01)


def test_zero_length_mission_uses_no_energy():
    r = chain().check(Mission("nothing", [Leg("hover", duration_s=0.0)], SEA_LEVEL_20C))
    assert r.energy_wh == 0 and r.charge_used_mah == 0 and r.remaining_fraction == 1


def test_energy_is_integral_of_power_and_charge_only_falls():
    r = chain("solo_survey.yaml").check(out_and_back(800, hold=60))
    assert r.energy_wh == pytest.approx(
        float(np.sum(r.legs.power_w * r.legs.duration_s)) / 3600)
    assert np.all(np.diff(r.series["remaining_fraction"]) <= 1e-12)
    assert r.legs.charge_mah.sum() == pytest.approx(r.charge_used_mah)


@pytest.mark.parametrize("aircraft", ["solo_survey.yaml", "x8_mapper.yaml"])
def test_headwind_lengthens_and_tailwind_shortens_the_same_leg(aircraft):
    """Airspeed held (fixed-wing; a multirotor leg given ``airspeed_ms``): ground speed
    is TAS ∓ wind, so the leg takes longer into the wind."""
    c = chain(aircraft)
    leg = [Leg("cruise", (0, 0), (2000, 0), 50, 50, speed_ms=12.0, speed_is_airspeed=True)]
    still = c.check(Mission("m", leg, Environment(0, 0)))
    head = c.check(Mission("m", leg, Environment(5, 90)))               # wind from the east
    tail = c.check(Mission("m", leg, Environment(5, 270)))
    assert head.duration_s > still.duration_s > tail.duration_s
    assert head.legs.groundspeed_ms[0] == pytest.approx(12 - 5)
    assert tail.legs.groundspeed_ms[0] == pytest.approx(12 + 5)
    assert head.duration_s == pytest.approx(2000 / 7)


def test_multirotor_holding_ground_speed_pays_in_airspeed_not_time():
    """A multirotor navigating at ground speed (ArduCopter WPNAV_SPEED) keeps the leg
    time in wind; the airspeed, and so the power, changes instead."""
    c = chain("solo_survey.yaml")
    leg = [Leg("cruise", (0, 0), (2000, 0), 50, 50)]                   # 8 m/s ground speed
    head = c.check(Mission("m", leg, Environment(5, 90)))
    tail = c.check(Mission("m", leg, Environment(5, 270)))
    assert head.duration_s == pytest.approx(tail.duration_s)
    assert head.legs.airspeed_ms[0] == pytest.approx(8 + 5)
    assert tail.legs.airspeed_ms[0] == pytest.approx(8 - 5)
    strong = c.check(Mission("m", leg, Environment(16, 90)))            # 24 m/s > max 20
    assert strong.legs.airspeed_ms[0] == pytest.approx(20.0)
    assert strong.legs.groundspeed_ms[0] == pytest.approx(4.0)
    assert strong.duration_s > head.duration_s


def test_crosswind_triangle_fixed_wing():
    c = chain("x8_mapper.yaml")
    leg = [Leg("cruise", (0, 0), (0, 3000), 50, 50)]                   # course 000°
    r = c.check(Mission("m", leg, Environment(6, 90)))                    # wind from the east
    assert r.legs.groundspeed_ms[0] == pytest.approx(np.sqrt(18**2 - 6**2))


def test_wind_stronger_than_aircraft_is_nogo_with_reason():
    c = chain("phoenix_s.yaml")
    leg = [Leg("cruise", (0, 0), (2000, 0), 50, 50, origin="legs[1]")]
    r = c.check(Mission("m", leg, Environment(30, 90)))
    assert r.verdict == "NO-GO"
    assert any("stronger than the aircraft can fly" in why for why in r.reasons)


def test_long_mission_is_nogo_with_landing_reserve_reason():
    r = chain().check(out_and_back(3000, hold=600))
    assert r.verdict == "NO-GO" and r.margin_mah < 0
    assert any("reserve" in why for why in r.reasons)


def test_short_mission_is_go_with_positive_margin_and_extra_hover_time():
    r = chain().check(out_and_back(300, hold=30))
    assert r.verdict == "GO" and r.margin_mah > 0 and r.margin_time_s > 0
    assert r.point_of_no_return is None


def test_reserve_setting_changes_the_verdict():
    mission = out_and_back(1000, hold=120)
    loose = chain(reserve=0.05).check(mission)
    strict = chain(reserve=0.9).check(mission)
    assert loose.margin_mah > strict.margin_mah
    assert strict.verdict == "NO-GO"


def test_point_of_no_return_found_on_a_one_way_trip():
    """Flying away without coming back: there is a point past which home is out of
    reach with the reserve, though the mission itself might end with charge left."""
    c = chain()
    legs = [Leg("climb", end_alt_m=20, origin="climb"),
            Leg("cruise", (0, 0), (0, 6000), 20, 20, origin="away"),
            Leg("descend", (0, 6000), (0, 6000), 20, 0, origin="land")]
    r = c.check(Mission("one way", legs, SEA_LEVEL_20C))
    pnr = r.point_of_no_return
    assert pnr is not None and pnr["leg_origin"] == "away"
    assert 0 < pnr["distance_home_m"] < 6000
    assert any("point of no return" in why for why in r.reasons)


def test_margin_time_is_consistent_with_hover_charge():
    """Spending the margin as hover lands exactly at the reserve."""
    c = chain()
    base = out_and_back(300, hold=30)
    r = c.check(base)
    extra = Mission("m", base.legs[:-1] + [Leg("hover", duration_s=r.margin_time_s)]
                    + base.legs[-1:], base.environment)
    r2 = c.check(extra)
    # the hover is flown at altitude (density differs by < 0.5 %), so allow a little slack
    assert r2.margin_mah == pytest.approx(0.0, abs=0.01 * r.margin_mah + 1)


def test_cold_dense_air_lowers_multirotor_power():
    c = chain()
    hover = [Leg("hover", duration_s=60)]
    cold = c.check(Mission("m", hover, Environment(temperature_c=-10)))
    hot = c.check(Mission("m", hover, Environment(temperature_c=35, site_altitude_m=2000)))
    assert cold.legs.power_w[0] < hot.legs.power_w[0]


def test_c_rating_violation_is_a_reason():
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    from dataclasses import replace
    weak = replace(pack, max_discharge_c=1.0)
    r = MissionChain(aircraft, weak).check(out_and_back(100))
    assert any("C rating" in why for why in r.reasons)


def test_loaded_current_closed_form():
    i = loaded_current(100.0, 16.0, 0.05)
    assert (16.0 - i * 0.05) * i == pytest.approx(100.0)
    assert np.isnan(loaded_current(16.0**2 / (4 * 0.05) * 1.01, 16.0, 0.05))


def test_payload_and_mtow():
    c = chain()
    m = out_and_back(100)
    m.payload_kg = 1.0
    r = c.check(m)
    assert r.takeoff_mass_kg == pytest.approx(1.6)
    assert any("maximum" in why and "take-off mass" in why for why in r.reasons)


def long_hover(minutes):
    return Mission("hover", [Leg("climb", end_alt_m=20, origin="climb"),
                             Leg("hover", duration_s=60 * minutes, origin="hold"),
                             Leg("descend", start_alt_m=20, end_alt_m=0, origin="land")])


def test_cold_pack_nogoes_a_mission_a_warm_pack_completes():
    """Issue 'Equivalent-circuit and thermal pack model': at 0 °C R0 rises (Arrhenius)
    and the available capacity falls, so the loaded voltage reaches the cut-off sooner."""
    mission = long_hover(18)
    warm = chain("solo_survey.yaml", temperature_c=25.0).check(mission)
    cold = chain("solo_survey.yaml", temperature_c=0.0).check(mission)
    assert warm.verdict == "GO", warm.reasons
    assert cold.verdict == "NO-GO"
    assert any("cut-off" in why and "0 °C" in why for why in cold.reasons)
    assert cold.circuit["voltage_margin_v"] < warm.circuit["voltage_margin_v"]
    assert cold.circuit["charge_to_cutoff_mah"] < warm.circuit["charge_to_cutoff_mah"]
    assert cold.circuit["max_temperature_c"] > 0.0      # I²R warms the pack in flight


def test_voltage_cutoff_inside_the_mission_is_a_voltage_reason():
    c = chain("solo_survey.yaml", temperature_c=-10.0, reserve=0.0)
    r = c.check(long_hover(30))
    assert r.verdict == "NO-GO"
    assert any("loaded voltage reaches the cut-off" in why for why in r.reasons)
    assert r.circuit["cutoff_time_s"] < r.duration_s


def test_without_circuit_block_the_simple_voltage_estimate_is_used():
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    from dataclasses import replace
    plain = replace(pack, circuit=None, thermal=None)
    r = MissionChain(aircraft, plain).check(long_hover(5))
    assert r.circuit is None and np.isfinite(r.min_voltage_v)


def test_best_speeds_fixed_wing_match_the_polar():
    """Without a stall limit in the way, the chain's max-endurance speed is (B/3A)^¼ and
    the max-range speed (B/A)^¼ of the drag polar at take-off mass (seed eq. 2–6)."""
    from dataclasses import replace
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/x8_mapper.yaml")
    ac = replace(aircraft, fixed_wing=replace(aircraft.fixed_wing, stall_speed_ms=5.0),
                 system_power_w=0.0)   # a constant load moves the range optimum faster
    r = MissionChain(ac, pack).check(Mission("m", [Leg("hover", duration_s=60)],
                                           SEA_LEVEL_20C))
    rho = 1.2041
    fw = ac.fixed_wing
    w = r.takeoff_mass_kg * 9.80665
    a = 0.5 * rho * fw.wing_area_m2 * fw.cd0
    b = 2 * fw.k * w**2 / (rho * fw.wing_area_m2)
    assert r.best_speeds["max_endurance_airspeed_ms"] == pytest.approx((b / (3 * a)) ** 0.25,
                                                                     rel=0.005)
    assert r.best_speeds["max_range_airspeed_ms"] == pytest.approx((b / a) ** 0.25, rel=0.005)
