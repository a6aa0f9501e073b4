"""Perceived-footprint error measurement (`bench.studies.hull_errors`)."""

import numpy as np

from tsad_drake.bench.studies.hull_errors import hull_errors, summary, support
from tsad_drake.scenes import generate_scenario


def test_support_of_a_square():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_allclose(support(square, np.array([0.0, np.pi / 2, np.pi, np.pi / 4])),
                               [1.0, 1.0, 0.0, np.sqrt(2)], atol=1e-12)


def test_perceived_hulls_are_close_to_the_true_footprints():
    scenario = generate_scenario("2", 0)
    rows = hull_errors(scenario)
    assert {r.name for r in rows} <= {o.name for o in scenario.objects} and len(rows) >= 8
    for r in rows:
        assert r.shortfall >= 0.0 and r.excess >= 0.0
        # a side where the hull falls short is a shortfall, one where it sticks out an excess
        assert r.shortfall >= -min(r.sides.values()) - 1e-12
        assert r.excess >= max(r.sides.values()) - 1e-12
    stats = summary(rows)
    assert stats["all"]["objects"] == len(rows)
    assert stats["all"]["shortfall_median_mm"] < 3.0  # seen objects are perceived to mm
    assert set(stats) >= {"cylinder", "all"}
