"""The seeded fuzz campaign of ``tools/fuzz.py`` (damaged and hostile input), in CI.

At least 500 cases across every log format (the shipped logs and, where present, the
real ones in ``../shared/data/logs``), the definition and mission formats and hostile
option values, through ``export``, ``replay``, ``diagnose``, ``check``, ``select``,
``sweep`` and ``hybrid``, each in a forked worker with a 10 s time limit and an
address-space limit. Any internal error (exit 3), hang, memory above 3 × the input's
size + 300 MB, changed input, stray file, exit 2 without one line naming the file, or
verdict on invalid input fails the test, which lists the failing cases.
"""

from __future__ import annotations

import random
import sys

import pytest

from tools import fuzz

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="the fuzzer forks workers "
                                "and reads /proc (Linux)")


def test_fuzz_campaign_of_500_cases_has_no_failure(tmp_path):
    rng = random.Random(20261125)
    cases = fuzz.log_cases(340, rng, tmp_path) + fuzz.def_cases(180, rng, tmp_path)
    rng.shuffle(cases)
    assert len(cases) >= 500
    assert {c.argv[0] for c in cases} >= {"export", "replay", "diagnose", "check", "select",
                                          "sweep", "hybrid"}
    results = fuzz.run_cases(cases, tmp_path, jobs=2)
    failing = [f"{r.case.name}: {'; '.join(r.failures)} :: {' '.join(r.case.argv)}"
               for r in results if r.failures]
    print(fuzz.summary(results))
    assert not failing, "\n".join(failing[:30])
    # garbage is refused, valid input is flown: both kinds of outcome occur
    assert any(r.status == 2 for r in results) and any(r.status == 0 for r in results)


def test_fuzzer_flags_an_internal_error_and_a_changed_input(tmp_path):
    """The judge itself: a crash, a hang-free exit 3 and a modified input are failures."""
    victim = tmp_path / "in.yaml"
    victim.write_text("a: 1\n")
    case = fuzz.Case("probe", "defs", ["check"], [str(victim)])
    before = fuzz._digest(case.inputs)
    victim.write_text("a: 2\n")
    failures = fuzz._judge(case, 3, 0.1, 0, "Traceback\nKeyError: 'x'\n", before, set())
    assert any(f.startswith("internal error: KeyError") for f in failures)
    assert "an input file changed" in failures
    ok = fuzz._judge(fuzz.Case("ok", "defs", ["check"], [str(victim)], invalid=True), 0, 0.1,
                     0, "", fuzz._digest([str(victim)]), fuzz._listing(tmp_path))
    assert ok == ["invalid input given a verdict (exit 0)"]


def test_records_outputs_and_options_sample_has_no_failure(tmp_path):
    """A seeded sample of the campaign's other doors, in under a minute: damaged
    flight-record CSVs (and .csv.gz) through replay, fit-aircraft, fit-battery and
    diagnose; every command's output options pointed at read-only files and folders,
    devices, links, missing folders and inputs; numeric options typed in a wrong unit.
    Besides the failures above, a read-only target replaced, a valid value refused, a
    verdict printed with ``nan`` or an unusable record given a verdict fails it."""
    rng = random.Random(20261126)
    cases = (fuzz.record_cases(250, rng, tmp_path) + fuzz.output_cases(100, rng, tmp_path)
             + fuzz.option_cases(60, rng, tmp_path))
    rng.shuffle(cases)
    assert {c.argv[0] for c in cases if c.kind == "records"} == {
        "replay", "fit-aircraft", "fit-battery", "diagnose"}
    assert any(c.invalid for c in cases if c.kind == "records")
    assert any(c.protected for c in cases if c.kind == "outputs")
    results = fuzz.run_cases(cases, tmp_path, jobs=2)
    fuzz._writable(tmp_path)
    failing = [f"{r.case.name}: {'; '.join(r.failures)} :: {' '.join(r.case.argv)}"
               for r in results if r.failures]
    print(fuzz.summary(results))
    assert not failing, "\n".join(failing[:30])
    # refusals and verdicts both occur in each kind
    for kind in ("records", "outputs", "options"):
        codes = {r.status for r in results if r.case.kind == kind}
        assert 2 in codes and 0 in codes, (kind, codes)


def test_judge_flags_a_replaced_read_only_file_a_refused_valid_value_and_nan(tmp_path):
    """The judge of the new kinds: a protected (read-only) target replaced, a valid
    option value refused with exit 2, and a verdict printed with nan are failures."""
    locked = tmp_path / "locked.json"
    locked.write_text("keep")
    locked.chmod(0o444)
    case = fuzz.Case("probe", "outputs", ["check"], [], protected=[str(locked)],
                     valid=True, folder=str(tmp_path))
    before = ({}, fuzz._state(case.protected))
    locked.unlink()
    locked.write_text("keep")                           # replaced by a writable file
    failures = fuzz._judge(case, 2, 0.1, 0, "error: --payload 0.35: refused\n", before,
                           fuzz._listing(tmp_path))
    assert any(f.startswith("protected path replaced") for f in failures)
    assert any(f.startswith("valid input refused") for f in failures)
    nan = fuzz._judge(fuzz.Case("v", "options", ["check"], []), 0, 0.1, 0, "", ({}, {}),
                      set(), stdout="Total 3.1 min; peak nan A\n")
    assert nan == ["nan or inf printed: Total 3.1 min; peak nan A"]
    clean = fuzz._judge(fuzz.Case("v", "options", ["check"], []), 0, 0.1, 0, "", ({}, {}),
                        set(), stdout="Financial note: 5 nano-things, information\n")
    assert clean == []
