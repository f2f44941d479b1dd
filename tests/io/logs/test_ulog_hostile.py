

def test_a_time_stamp_163_000_years_after_boot_is_dropped_not_gridded():
    """Found by the fuzz campaign: a duplicated chunk of a ULog left one battery sample at
    t = 5e12 s, and diagnose laid 4e10 windows over the flight (321 GiB). Samples beyond a
    gap of more than 6 h are dropped with a warning."""
    import warnings

    import numpy as np

    from planner.io.logs._common import Channel, Meta, build_record

    t = np.r_[np.arange(0.0, 100.0, 0.5), 5.0e12]
    channels = {"voltage_v": Channel("voltage_v", t, np.full(t.size, 16.0), "BAT.Volt", "BAT"),
                "current_a": Channel("current_a", t, np.full(t.size, 10.0), "BAT.Curr", "BAT")}
    meta = Meta("x.bin", "test")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = build_record(channels, meta, experiment="x")
    assert df["time_s"].max() < 100.0 and len(df) == 200
    assert any("gap of more than 6 h" in str(w.message) for w in caught)
