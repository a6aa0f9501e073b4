"""Wilson intervals of success rates, as the results page prints them."""

import pytest

from tsad_drake.bench.metrics import intervals_overlap, paper_table, summarise, wilson_interval


def test_wilson_interval_matches_the_known_values():
    # 28 / 30: the example, about 0.79-0.98
    low, high = wilson_interval(28, 30)
    assert low == pytest.approx(0.7868, abs=1e-3) and high == pytest.approx(0.9815, abs=1e-3)
    assert wilson_interval(30, 30)[1] == 1.0 and wilson_interval(30, 30)[0] == pytest.approx(0.8865, abs=1e-3)
    assert wilson_interval(0, 10)[0] == 0.0
    assert wilson_interval(0, 0) == (0.0, 1.0)
    # more episodes, narrower interval around the same rate
    a, b = wilson_interval(9, 10), wilson_interval(90, 100)
    assert b[1] - b[0] < a[1] - a[0] and a[0] < 0.9 < a[1] and b[0] < 0.9 < b[1]


def test_overlap_tells_whether_two_rates_are_apart():
    assert intervals_overlap(wilson_interval(28, 30), wilson_interval(26, 30))
    assert not intervals_overlap(wilson_interval(95, 100), wilson_interval(40, 100))


def test_summary_and_table_carry_the_interval():
    rows = [{"success": i < 28, "num_actions": 3, "falls": 0} for i in range(30)]
    s = summarise(rows)
    assert s["success_interval_95"] == pytest.approx(list(wilson_interval(28, 30)))
    assert "0.79-0.98" in paper_table({"tsad": s})
