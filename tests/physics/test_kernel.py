"""Compiled loops run interpreted for short work (planner.physics.kernel): the same answers
either way, the budget switches a process to the compiled code, and the shipped survey's
check stays within the budget (its start-up, benchmarks/bench_startup.py)."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from planner.cli.main import main
from planner.physics import kernel as kernel_mod
from planner.physics.battery.circuit import CircuitParameters, simulate
from planner.physics.battery.thermal import ThermalParameters
from planner.physics.kernel import Kernel
from planner.physics.power import momentum

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def run_as(monkeypatch):
    """Set how the process's kernels run: ``"compiled"`` or ``"interpreted"``."""
    def set_mode(mode):
        monkeypatch.setattr(Kernel, "spent", 0)
        monkeypatch.setattr(Kernel, "started", mode == "compiled")
        monkeypatch.setattr(kernel_mod, "INTERPRETED_ELEMENTS", 10**9)
    return set_mode


def _circuit():
    p = CircuitParameters(capacity_ah=2.5, r0_ohm=0.025, r1_ohm=0.012, c1_f=1500.0,
                          cells_series=4, cells_parallel=2, hysteresis_v=0.02,
                          hysteresis_gamma=30.0)
    t = np.arange(0.0, 3000.0, 1.0)
    power = np.where((t // 120) % 2 == 0, 180.0, 60.0)
    thermal = ThermalParameters(r_th_k_per_w=2.0, c_th_j_per_k=300.0, t_air_c=5.0,
                                t0_c=5.0)
    return simulate(p, t, power_w=power, soc0=0.95, temperature_c=thermal,
                    v_cutoff_cell=3.3, stop_at_cutoff=True)


def test_circuit_interpreted_gives_the_compiled_answers(run_as):
    run_as("compiled")
    fast = _circuit()
    run_as("interpreted")
    slow = _circuit()
    assert Kernel.spent > 0 and not Kernel.started
    assert slow.time_s.size == fast.time_s.size
    for name in ("current_a", "voltage_v", "soc", "hysteresis_v", "rc_voltage_v",
                 "temperature_c", "charge_as"):
        assert_allclose(getattr(slow, name), getattr(fast, name), rtol=1e-12, atol=1e-12,
                        err_msg=name)


def test_rotor_inflow_interpreted_gives_the_compiled_answers(run_as):
    axial = np.linspace(-8.0, 8.0, 41)[:, None]
    inplane = np.linspace(0.0, 20.0, 31)[None, :]
    run_as("compiled")
    fast = momentum.induced_from_components(6.0, axial, inplane)
    run_as("interpreted")
    slow = momentum.induced_from_components(6.0, axial, inplane)
    assert Kernel.spent >= axial.size * inplane.size // 2
    assert_allclose(slow, fast, rtol=1e-13)


def test_check_prints_the_same_report_interpreted_and_compiled(run_as, capsys):
    argv = ["check", str(REPO / "missions/survey_route.yaml"), "--aircraft",
            str(REPO / "aircraft/solo_survey.yaml")]
    run_as("compiled")
    assert main(argv) == 0
    fast = capsys.readouterr().out
    run_as("interpreted")
    assert main(argv) == 0
    slow = capsys.readouterr().out
    assert "GO" in fast
    assert slow == fast


def test_the_budget_switches_the_process_to_compiled_code(monkeypatch):
    monkeypatch.setattr(Kernel, "spent", 0)
    monkeypatch.setattr(Kernel, "started", False)
    monkeypatch.setattr(kernel_mod, "INTERPRETED_ELEMENTS", 100)
    x = np.linspace(0.0, 1.0, 60)
    momentum._glauert_ratio(1.0, x)                 # 60 elements: interpreted
    assert (Kernel.spent, Kernel.started) == (60, False)
    momentum._glauert_ratio(1.0, x)                 # 120 > 100: compiled from here on
    assert (Kernel.spent, Kernel.started) == (60, True)
    momentum._glauert_ratio(1.0, x[:5])
    assert (Kernel.spent, Kernel.started) == (60, True)


def test_the_shipped_survey_check_runs_no_compiled_kernel():
    """The start-up target of `endurance check` rests on it (benchmarks/bench_startup.py):
    numba's first call costs 0.29 s of CPU, more than the whole check interpreted. No
    compiled function of the planner, kernel or element, is loaded in the process."""
    code = """
import json, sys
from numba.core.dispatcher import Dispatcher
from planner.cli.main import main
from planner.physics.kernel import Kernel
rc = main(['check', 'missions/survey_route.yaml', '--aircraft', 'aircraft/solo_survey.yaml'])
loaded = sorted(f'{name}.{k}' for name, mod in list(sys.modules.items())
                if name.startswith('planner.') for k, v in vars(mod).items()
                if (isinstance(v, Dispatcher) and v.signatures)
                or (isinstance(v, Kernel) and v.compiled.signatures))
print(json.dumps([rc, Kernel.spent, Kernel.started, loaded]), file=sys.stderr)
"""
    out = subprocess.run([sys.executable, "-c", code], check=False, cwd=REPO,
                         capture_output=True,
                         text=True, timeout=120)
    rc, spent, started, loaded = json.loads(out.stderr.strip().splitlines()[-1])
    assert rc == 0
    assert spent > 0
    assert not started
    assert loaded == []
