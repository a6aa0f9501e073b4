"""The `net` FeasibilityModel: batched = single, per-state cache, consistent answers, placements."""

import numpy as np
import pytest
import torch

from tsad_drake.errors import UsageError
from tsad_drake.prehensile import dataset as pdata
from tsad_drake.prehensile import encoding
from tsad_drake.prehensile.checkpoint import save_checkpoint
from tsad_drake.prehensile.feasibility import NetFeasibility
from tsad_drake.prehensile.network import PrehensileNet
from tsad_drake.prehensile.weights import DEFAULT_WEIGHTS


@pytest.fixture(scope="module")
def weights(tmp_path_factory):
    """The shipped weights when built, else a seeded untrained network (the plumbing is the same)."""
    if DEFAULT_WEIGHTS.is_file():
        return DEFAULT_WEIGHTS
    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("net") / "w.pt"
    save_checkpoint(PrehensileNet(), path, {})
    return path


@pytest.fixture(scope="module")
def states():
    return pdata.scene_states(3, relocations=1, reobserve=False)  # observed + one relocation


def test_batched_and_single_predictions_agree(weights, states):
    for _, state, oracle in states:
        batched = NetFeasibility(oracle.workspace, weights, batch_size=64)
        single = NetFeasibility(oracle.workspace, weights, batch_size=1)
        batched.evaluate_all(state)
        n, a = len(state.objects), len(oracle.workspace.approach_angles)
        assert batched.evaluations == n * a
        for i in range(n):
            assert batched.blockers(state, i) == single.blockers(state, i)
            np.testing.assert_array_equal(batched.pickable(state, i), single.pickable(state, i))
            np.testing.assert_array_equal(batched.reachable(state, i), single.reachable(state, i))
        assert single.evaluations == n * a


def test_cache_and_consistency(weights, states):
    _, state, oracle = states[0]
    model = NetFeasibility(oracle.workspace, weights)
    t = state.target_index
    first = model.blockers(state, t)
    count = model.evaluations
    assert count == len(oracle.workspace.approach_angles)
    assert model.blockers(state, t) == first and model.evaluations == count  # cache hit
    pick, reach = model.pickable(state, t), model.reachable(state, t)
    assert model.evaluations == count
    for k, blockers in enumerate(first):
        assert t not in blockers
        assert pick[k] == (reach[k] and not blockers)
    assert model.throughput() > 0


def test_one_angle_blockers_agree_with_all_angle_answers(weights, states):

    _, state, oracle = states[0]
    lazy, full = NetFeasibility(oracle.workspace, weights), NetFeasibility(oracle.workspace, weights)
    t, k = state.target_index, 3
    num_angles = len(oracle.workspace.approach_angles)
    assert lazy.blockers_at(state, t, k) == full.blockers(state, t)[k]
    assert lazy.evaluations == 1  # one angle, one query
    np.testing.assert_array_equal(lazy.pickable(state, t), full.pickable(state, t))
    assert lazy.evaluations == num_angles  # the other angles in one batch, angle k cached


def test_first_place_option_is_the_first_valid_cell_of_place_options(weights, states):
    from tsad_drake.planning.actions import choose_theta_pick

    _, state, oracle = states[0]
    ws = oracle.workspace
    full, lazy = NetFeasibility(ws, weights), NetFeasibility(ws, weights)
    checked = 0
    for i in range(len(state.objects)):
        theta = choose_theta_pick(full, state, i, ws)
        if theta is None or i == state.target_index:
            continue
        options = full.place_options(state, i, theta)
        order = list(np.random.default_rng(i).permutation(len(ws.cell_centres)))
        valid = [c for c in order if np.isfinite(options[c])]
        found = lazy.first_place_option(state, i, theta, order)
        if valid:
            assert found == (valid[0], options[valid[0]])
            checked += 1
        else:
            assert found is None
    assert checked > 0


def test_a_placement_batch_carries_the_next_states_target_query(weights, states):
    """After the target's R was asked at angle k, a placement check also answers the target at k
    in each next state it tried, in the same forward pass; those answers are a fresh model's."""
    from tsad_drake.planning.actions import choose_theta_pick

    _, state, oracle = states[0]
    ws = oracle.workspace
    t, k = state.target_index, 3
    model = NetFeasibility(ws, weights)
    model.blockers_at(state, t, k)
    mover = next(i for i in range(len(state.objects))
                 if i != t and choose_theta_pick(model, state, i, ws) is not None)
    theta = choose_theta_pick(model, state, mover, ws)
    cells = list(range(len(ws.cell_centres)))
    found = model.first_place_option(state, mover, theta, cells)
    assert found is not None
    nxt, _, _ = model._place_request(state, mover, theta, found[0], found[1])
    before = model.evaluations
    fresh = NetFeasibility(ws, weights)
    assert model.blockers_at(nxt, t, k) == fresh.blockers_at(nxt, t, k)
    assert model.evaluations == before  # answered in the placement's batch


def test_place_options_are_network_checked_geometric_proposals(weights, states):
    from tsad_drake.planning.pointcloud_sim import simulate_pick_place
    from tsad_drake.planning.types import Action

    _, state, oracle = states[0]
    model = NetFeasibility(oracle.workspace, weights)
    thetas = oracle.workspace.approach_angles
    i = next(j for j in range(len(state.objects)) if j != state.target_index)
    options = model.place_options(state, i, 0.0)
    proposal = model.placement_model.place_options(state, i, 0.0)
    assert options.shape == (len(oracle.workspace.cell_centres),)
    kept = ~np.isnan(options)
    assert not (kept & np.isnan(proposal)).any()
    for c in np.nonzero(kept)[0]:
        assert np.isclose(thetas, options[c]).any()
        x, y = oracle.workspace.cell_centres[c]
        nxt = simulate_pick_place(state, Action(state.objects[i].name, 0.0, x, y, options[c]))
        k = int(np.argmin(np.abs(thetas - options[c])))
        assert model.pickable(nxt, i)[k]
    assert model.place_options(state, i, 0.0) is options  # memoised


def test_missing_weights_are_bad_input(states, tmp_path):
    with pytest.raises(UsageError, match="not found"):
        NetFeasibility(states[0][2].workspace, tmp_path / "missing.pt")


@pytest.mark.skipif(not DEFAULT_WEIGHTS.is_file(), reason="shipped weights not built yet")
def test_make_feasibility_builds_the_net_model(states):
    from tsad_drake.pipeline import make_feasibility

    _, _, oracle = states[0]
    model = make_feasibility("net", oracle.scenario, oracle.workspace)
    assert isinstance(model, NetFeasibility) and model.name == "net"


def test_a_query_whose_window_did_not_change_reuses_its_answer(weights, states):
    """After a relocation, every query whose encoded input is bit for bit the parent state's is
    answered without a forward pass, and all answers equal a fresh model's."""
    _, state, oracle = states[0]
    ws = oracle.workspace
    moved = pdata.random_relocation(state, oracle, np.random.default_rng(5))
    assert moved is not None
    model = NetFeasibility(ws, weights)
    model.evaluate_all(state)
    before = model.evaluations
    model.evaluate_all(moved)
    n, a = len(moved.objects), len(ws.approach_angles)
    thetas = ws.approach_angles
    old, new = encoding.state_cloud(state, ws), encoding.state_cloud(moved, ws)
    same = sum(all(np.array_equal(p, q) for p, q in zip(encoding.encode_query(old, i, float(thetas[k]), k),
                                                          encoding.encode_query(new, i, float(thetas[k]), k)))
               for i in range(n) for k in range(a))
    assert 0 < same < n * a
    assert model.reused_inputs == same
    assert model.evaluations - before == n * a - same
    fresh = NetFeasibility(ws, weights)
    for i in range(n):
        assert model.blockers(moved, i) == fresh.blockers(moved, i)
        np.testing.assert_array_equal(model.reachable(moved, i), fresh.reachable(moved, i))


def test_pick_angles_asked_lazily_are_the_batched_ones_at_fewer_queries(weights, states):
    from tsad_drake.planning.actions import cached_pick_angles, lazy_pick_angles
    from tsad_drake.planning.interface import approach_order

    first_only = 0
    for _, state, oracle in states:
        ws = oracle.workspace
        lazy, eager = NetFeasibility(ws, weights), NetFeasibility(ws, weights)
        for i in range(len(state.objects)):
            for prefer in (0.0, float(ws.approach_angles[0])):
                before = lazy.evaluations
                taken = next(lazy_pick_angles(lazy, state, i, ws, prefer), None)
                asked = lazy.evaluations - before
                angles = cached_pick_angles(eager, state, i, ws, prefer)
                assert taken == (angles[0] if angles else None)
                nearest = float(ws.approach_angles[approach_order(ws.approach_angles, prefer)[0]])
                if taken == nearest and asked:  # the preferred angle works: one query, not seven
                    assert asked == 1
                    first_only += 1
                # the caller that wants every angle gets the batched list, in its order
                assert list(lazy_pick_angles(lazy, state, i, ws, prefer)) == angles
                assert eager.pickable_at(state, i, 3) == bool(eager.pickable(state, i)[3])
    assert first_only > 0
