"""The simulator API (patients, units, open-loop runs, scenario runs) and
the ABBA advisor object."""

import numpy as np
import pytest

import abba


def test_patients_and_parameters():
    names = abba.public_patients()
    assert len(names) == 30 and "adult#001" in names and "child#010" in names
    p = abba.patient_params("adult#001")
    assert p["BW"] > 40 and p["x0_ 4"] > 0
    g = abba.patient_params("adult#042")  # a generated cohort member
    assert g["BW"] != p["BW"]
    c = abba.cohort("children", 12, seed=3)
    assert len(c) == 12 and (c["carb_ratio_g_per_u"] > 0).all()
    assert list(c["patient"][:10]) == [f"child#{i:03d}" for i in range(1, 11)]
    assert set(abba.STATE_UNITS) == set(abba._abba.state_names())


def test_open_loop_run_at_basal_matches_the_rust_reference():
    p = abba.patient_params("adult#001")
    basal = p["u2ss"] * p["BW"] / 6000.0  # U/min
    df = abba.simulate("adult#001", np.zeros(60), np.full(60, basal))
    assert len(df) == 61 and list(df.columns) == ["minute", "plasma_mg_dl", "subcutaneous_mg_dl"]
    # Same value as the abba-sim doc test: 60 min at basal.
    assert abs(df["plasma_mg_dl"].iloc[-1] - 138.56) < 1e-2
    # A meal raises glucose, insulin lowers it.
    meal = np.zeros(240)
    meal[10:20] = 5.0
    fed = abba.simulate("adult#001", meal, np.full(240, basal))
    more = abba.simulate("adult#001", meal, np.full(240, 2 * basal))
    assert fed["plasma_mg_dl"].max() > df["plasma_mg_dl"].max() + 30
    assert more["plasma_mg_dl"].iloc[-1] < fed["plasma_mg_dl"].iloc[-1]
    with pytest.raises(ValueError, match="insulin"):
        abba.simulate("adult#001", np.zeros(3), np.array([0.0, -1.0, 0.0]))


def test_scenario_run_dataframe():
    df = abba.run_scenario("adult#002", "S2", "standard",
                           config={"patients": 2, "days": 10, "scenarios": ["S2"]})
    assert len(df) == 10 * 1440
    assert df["cgm_mg_dl"].notna().sum() == 8 * 288  # CGM on D1-D8 only
    assert df["smbg_mg_dl"].notna().sum() >= 4 * 9
    assert (df["basal_u_per_h"] > 0).all()


def feed_day(advisor, day, glucose, carbs=(50, 60, 80), cr=None):
    """One CGM-mode day: readings every 5 min, three meals with boluses."""
    base = day * 1440
    out = None
    meals = {7 * 60: ("breakfast", carbs[0]), 12 * 60: ("lunch", carbs[1]),
             18 * 60: ("dinner", carbs[2])}
    for m in range(0, 1440, 5):
        r = advisor.cgm(base + m, glucose(m))
        out = r or out
        if m in meals:
            slot, g = meals[m]
            advisor.meal(base + m, g, slot)
            ratio = advisor.settings["carb_ratio_g_per_u"][slot]
            advisor.bolus(base + m, g / ratio)
    return out


def test_abba_answers_with_settings_after_its_initialisation_week():
    a = abba.Abba(basal_u_per_h=1.0, carb_ratio_g_per_u=10.0, mode="cgm")
    high = lambda m: 220.0 + 20.0 * np.sin(m / 200.0)  # noqa: E731
    answers = []
    for day in range(1, 11):
        feed_day(a, day, high)
        answers.append(a.day_closed((day + 1) * 1440))
    assert all(x is None for x in answers[:6])
    assert a.initialised
    later = [x for x in answers if x is not None]
    assert later, answers
    # Hyperglycaemia all day: the basal rate moves up, within 5 % a day.
    basal = [1.0] + [x["basal_u_per_h"] for x in later]
    assert basal[-1] > 1.0
    for prev, new in zip(basal, basal[1:]):
        assert new <= prev * 1.05 + 1e-9
    assert a.decisions(), "every decision carries its explanation"
    # Out-of-order events are refused and change nothing.
    before = a.save()
    with pytest.raises(ValueError):
        a.cgm(5, 120.0)
    assert a.save() == before
    # Resume from the saved state: the same answers.
    b = abba.Abba.load(before)
    assert feed_day(a, 11, high) == feed_day(b, 11, high)
    assert a.day_closed(12 * 1440) == b.day_closed(12 * 1440)
