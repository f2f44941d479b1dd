"""The virtual bench (planner.identify.bench): its physics, its cut-off, its noise.

The bench must not be the integral model it is used to identify: its loaded
voltage sags with current, it stops at the loaded cut-off, and the charge it
delivers by the cut-off falls with power by the amount its documented
diffusion state withholds (module notes of :mod:`planner.identify.bench`).
"""

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from planner.io import record
from planner.identify import bench, protocols as design, battery_fit as fit
from planner.errors import InputError
from planner.parameters import load_battery

POWERS = (50.0, 75.0, 100.0, 125.0)
LONG = np.arange(0.0, 12 * 3600.0)  # 1 Hz, longer than any discharge here


@pytest.fixture(scope="module")
def pack():
    return bench.seed_pack()


@pytest.fixture(scope="module")
def no_diffusion(pack):
    """The same pack without the diffusion state: the plain equivalent circuit."""
    return pack.with_changes(available_fraction=1.0)


@pytest.fixture(scope="module")
def to_cutoff(pack, no_diffusion):
    """Noise-free constant-power runs to the cut-off, with and without diffusion."""
    return {p: (bench.simulate_bench(pack, LONG, p), bench.simulate_bench(no_diffusion, LONG, p))
            for p in POWERS}


# --------------------------------------------------------------------------- the pack

def test_seed_pack_is_the_shipped_multistar_yaml(repo, pack):
    """seed_pack() holds the numbers of aircraft/batteries/multistar_10ah_4s.yaml."""
    from_yaml = bench.BenchPack.from_battery(
        load_battery(repo / "aircraft" / "batteries" / "multistar_10ah_4s.yaml"))
    a, b = pack.circuit, from_yaml.circuit
    assert (a.cells_series, a.cells_parallel) == (b.cells_series, b.cells_parallel) == (4, 1)
    assert_allclose([a.capacity_ah, a.r0_ohm, a.r1_ohm, a.c1_f],
                    [b.capacity_ah, b.r0_ohm, b.r1_ohm, b.c1_f], rtol=1e-12)
    # [UAV23] Table 2: 20.68 mΩ for the pack
    assert_allclose(pack.r_pack_ohm, 0.02068, rtol=1e-12)
    assert pack.v_cutoff_cell == from_yaml.v_cutoff_cell == 3.5
    # [UAV23] Table 5, m_const, designs the two-step tests
    assert_allclose([from_yaml.model[k] for k in ("delta", "epsilon", "beta")],
                    [23.6482, -1.0209, 0.9648])
    assert pack.model == from_yaml.model


# --------------------------------------------------------------------------- physics

def test_loaded_voltage_sags_with_current(pack):
    """At a 50 → 125 W step the voltage falls by R0·ΔI at once, then the RC branch sags it more."""
    test = design.two_step(50.0, 125.0, 1.0, 8000 * 3.6, **pack.model)
    t = np.arange(0.0, test.total_s)
    r = bench.simulate_bench(pack, t, design.sample_schedule(test.schedule(), t))
    k = int(np.ceil(test.t1_s))  # first sample of the second step
    d_i = r.current_a[k] - r.current_a[k - 1]
    assert d_i > 4.0  # about 3.3 A -> 8 A
    d_v = r.voltage_v[k - 1] - r.voltage_v[k]
    # instantaneous drop: pack R0 x ΔI (the states move by 1 s of discharge only)
    assert d_v == pytest.approx(pack.r_pack_ohm * d_i, rel=0.03)
    # then it keeps sagging as the RC branch (3 mΩ per cell, τ = 30 s) charges: 2 min
    # later at least a further 4 x 3 mΩ x ΔI x (1 − e^-4) below (plus the OCV's fall)
    rc = 4 * pack.circuit.r1_ohm * d_i * (1 - math.exp(-120 / 30))
    assert r.voltage_v[k] - r.voltage_v[k + 120] > rc
    # a step down recovers the same R0·ΔI at once
    back = bench.simulate_bench(pack, t, np.where(t < k, 125.0, 50.0))
    d_i2 = back.current_a[k - 1] - back.current_a[k]
    assert back.voltage_v[k] - back.voltage_v[k - 1] == pytest.approx(
        pack.r_pack_ohm * d_i2, rel=0.03)
    # the integral model has no voltage at all: the bench's power is V·I exactly
    assert_allclose(r.power_w, r.voltage_v * r.current_a, rtol=1e-12)


def test_run_stops_at_the_loaded_cutoff(pack, to_cutoff):
    for p, (r, _) in to_cutoff.items():
        cell = r.voltage_v / 4
        assert r.tripped
        assert cell[-1] <= 3.5 < cell[-2], p
        assert np.all(cell[:-1] > 3.5)
        assert r.time_s[-2] <= r.cutoff_time_s <= r.time_s[-1]
        assert r.charge_as[-2] <= r.cutoff_charge_as <= r.charge_as[-1]
        # the rested pack is far from empty: the knee of the OCV, not SoC 0
        assert 0.03 < r.soc[-1] < 0.15
    # the logged record ends at the same sample
    rec = bench.constant_power_discharge(pack, 100.0, seed=0)
    assert len(rec) == to_cutoff[100.0][0].time_s.size


def test_charge_at_cutoff_falls_with_power_by_the_documented_amount(pack, to_cutoff):
    """C_cut falls with P; the part beyond the plain circuit's IR loss is Q·x ≈ (1−c)/c·τ_d·I."""
    c_cut = np.array([to_cutoff[p][0].cutoff_charge_as for p in POWERS])
    c_circuit = np.array([to_cutoff[p][1].cutoff_charge_as for p in POWERS])
    assert np.all(np.diff(c_cut) < 0)
    assert np.all(np.diff(c_circuit) < 0)  # the IR drop alone already does a little
    # the diffusion's share: exactly the withheld surface deficit at the cut-off ...
    for p in POWERS:
        r, r0 = to_cutoff[p]
        lost = r0.cutoff_charge_as - r.cutoff_charge_as
        assert lost == pytest.approx(r.withheld_charge_as, rel=0.02), p
        # ... which is the steady-current formula of the module notes, with the
        # current of the last τ_d (the current rises towards the cut-off)
        window = r.time_s > r.time_s[-1] - pack.diffusion_tau_s
        steady = pack.withheld_s_per_a * r.current_a[window].mean()
        assert lost == pytest.approx(steady, rel=0.05), p
    # the rate effect is larger than the circuit's own: 50 → 125 W
    drop = c_cut[0] - c_cut[-1]
    drop_circuit = c_circuit[0] - c_circuit[-1]
    assert drop > 2.5 * drop_circuit
    assert 0.02 < drop / c_cut[0] < 0.04  # 2.7 % with the defaults (module notes)


def test_withheld_charge_recovers_at_rest(pack, no_diffusion):
    """After a 30 min rest the pack gives back most of what diffusion withheld (recovery)."""
    rest = 1800.0
    extra = {}
    for name, pk in (("bench", pack), ("circuit", no_diffusion)):
        first = bench.simulate_bench(pk, LONG, 125.0)
        tc = first.time_s[-1]
        t = np.arange(0.0, tc + rest + 3000.0)
        power = np.where(t <= tc, 125.0, np.where(t < tc + rest, 0.0, 125.0))
        r = bench.simulate_bench(pk, t, power, stop_at_cutoff=False)
        cell = r.voltage_v / 4
        k1 = int(np.flatnonzero(cell <= 3.5)[0])
        k2 = int(np.flatnonzero((t >= tc + rest) & (cell <= 3.5))[0])
        extra[name] = r.charge_as[k2] - r.charge_as[k1]
        if name == "bench":
            withheld = first.withheld_charge_as
    recovered = extra["bench"] - extra["circuit"]
    assert recovered > 0.5 * withheld * (1 - math.exp(-rest / pack.diffusion_tau_s))
    assert recovered < withheld


# --------------------------------------------------------------------------- records and noise

def test_record_is_a_flight_record_fit_battery_reads(pack):
    rec, truth = bench.constant_power_discharge(pack, 75.0, seed=4, return_truth=True)
    assert list(rec.columns) == list(bench.RECORD_COLUMNS)
    assert (rec["experiment"] == "const_075W").all()
    record.validate_record(rec)
    (exp,) = fit.prepare_experiments(rec)
    assert exp.mean_power_w == pytest.approx(75.0, rel=2e-3)
    # consumed_mah is the logger's sum of the measured current
    i = rec["current_a"].to_numpy()
    assert_allclose(rec["consumed_mah"].to_numpy()[1:], np.cumsum(i[:-1]) / 3.6, rtol=1e-12)
    assert_allclose(rec["power_w"], rec["voltage_v"] * rec["current_a"], rtol=1e-12)
    # ... and stays within a few mAh of the true charge (random walk of 0.05 A noise)
    assert_allclose(rec["consumed_mah"].to_numpy(), truth.charge_as / 3.6, atol=5.0)


def test_noise_is_seeded_reproducible_and_of_the_stated_size(pack):
    noise = bench.BenchNoise(voltage_v=0.02, current_a=0.1)
    a, truth = bench.constant_power_discharge(pack, 125.0, seed=7, noise=noise,
                                              return_truth=True)
    b = bench.constant_power_discharge(pack, 125.0, seed=7, noise=noise)
    c = bench.constant_power_discharge(pack, 125.0, seed=8, noise=noise)
    pd.testing.assert_frame_equal(a, b)
    assert not np.allclose(a["current_a"], c["current_a"])
    assert_array_equal(a["time_s"], c["time_s"])  # the noise does not move the cut-off
    dv = a["voltage_v"].to_numpy() - truth.voltage_v
    di = a["current_a"].to_numpy() - truth.current_a
    assert np.std(dv) == pytest.approx(0.02, rel=0.1)
    assert np.std(di) == pytest.approx(0.1, rel=0.1)
    assert abs(np.mean(di)) < 4 * 0.1 / np.sqrt(di.size)
    clean = bench.constant_power_discharge(pack, 125.0, noise=bench.NO_NOISE)
    assert_allclose(clean["voltage_v"], truth.voltage_v, rtol=0, atol=0)


def test_schedule_end_and_load_off(pack):
    """A schedule that ends first ends the record; a rest logs zero power."""
    schedule = pd.DataFrame({"start_s": [0.0, 600.0, 900.0], "duration_s": [600.0, 300.0, 600.0],
                             "power_w": [100.0, 0.0, 50.0]})
    rec, truth = bench.run_schedule(pack, schedule, "rest", seed=1, return_truth=True)
    assert not truth.tripped
    assert rec["time_s"].iloc[-1] == 1499.0
    rest = rec[(rec.time_s >= 600) & (rec.time_s < 900)]
    assert (rest["power_w"] == 0.0).all()
    assert_allclose(truth.current_a[600:900], 0.0)
    # at rest the voltage recovers (RC and diffusion relax)
    assert truth.voltage_v[899] > truth.voltage_v[600] > truth.voltage_v[599]


def test_two_step_and_aprbs_tests(pack):
    two = bench.two_step_discharge(pack, 125.0, 50.0, 2.0, 8000.0, seed=2)
    test = design.two_step(125.0, 50.0, 2.0, 8000 * 3.6, **pack.model)
    assert two["experiment"].iloc[0] == "two_step_125_050_k2"
    assert len(two) == math.ceil(test.total_s - 0.5)
    ap = bench.aprbs_discharge(pack, 5, seed=3)
    schedule = design.aprbs([50, 75, 100, 125], (30, 300), 3500, 5)
    assert ap["experiment"].iloc[0] == "aprbs_5"
    assert len(ap) >= 3500
    on = ap["power_w"].to_numpy()
    want = design.sample_schedule(schedule, ap["time_s"].to_numpy())
    # constant-power control, measured with noise: σ ≈ 15 V x 0.05 A
    err = on - want
    assert np.max(np.abs(err)) < 6 * 0.8
    assert abs(err.mean()) < 0.05


def test_bad_input():
    pack = bench.seed_pack()
    with pytest.raises(InputError, match="power_w"):
        bench.simulate_bench(pack, [0.0, 1.0, 2.0], [10.0, -5.0, 10.0])
    with pytest.raises(InputError, match="time_s"):
        bench.simulate_bench(pack, [0.0, 2.0, 1.0], 10.0)
    with pytest.raises(ValueError, match="available_fraction"):
        pack.with_changes(available_fraction=0.0)
    with pytest.raises(ValueError, match="diffusion_tau_s"):
        pack.with_changes(diffusion_tau_s=-1.0)
    with pytest.raises(ValueError, match="current_a"):
        bench.BenchNoise(current_a=-0.1)
    with pytest.raises(ValueError, match="power_w"):
        bench.constant_power_discharge(pack, 0.0)
