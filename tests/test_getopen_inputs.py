"""GO:L's input scaling and tie-break (docs/design.md, "Learning options"): the scaling folded into the net,
the per-kind rule, its place in policy files, checkpoints and advice, and ties between grid points."""

from __future__ import annotations

import json

import numpy as np
import pytest

from beliefs import belief
from keepaway.agents.config import AgentConfig
from keepaway.agents.getopen import (
    RAW_INPUTS,
    SCALED_INPUTS,
    GetOpenScaling,
    InputScaling,
    getopen_input_scaling,
    lane_origin,
    learned_target,
    net_size,
    net_value,
)
from keepaway.agents.policy_file import POLICY_VERSION, PolicyFileError, load_policy, save_policy
from keepaway.agents.state_vars import getopen_state_kinds, getopen_state_size
from keepaway.protocol.params import parameter_set
from keepaway.runner.coached import policy_advice
from keepaway.trainer.curves import CurvePoint
from keepaway.trainer.train import (
    TrainConfig,
    TrialState,
    initial_behaviours,
    load_checkpoint,
    save_checkpoint,
    trial_dir,
    write_trial_outputs,
)

KP = parameter_set("classic").kernel()
CFG = AgentConfig().kernel()
N_INPUTS = getopen_state_size(3, 2)
THETA_SIZE = net_size(N_INPUTS)
# theta layout (agents.getopen.net_value), 10 inputs: W1 0..49, b1 50..54, W2 55..79, b2 80..84, W3 85..89, b3 90
B1, W2, W3 = 50, 55, 85


def random_states(rng, n):
    """GetOpen-like raw states: distances 0-30 m, angles 0-180 deg (3v2 layout)."""
    x = rng.uniform(0.0, 30.0, (n, N_INPUTS))
    angles = [i for i, kind in enumerate(getopen_state_kinds(3, 2)) if not kind.endswith("distance")]
    x[:, angles] = rng.uniform(0.0, 180.0, (n, len(angles)))
    return x


# -- the transformation ------------------------------------------------------------------------------
def test_fold_divides_the_first_layer_and_moves_its_bias_by_hand():
    # 2 inputs, unit 0: W1 row (2, -3), b1 = 1; mean (4, 10), scale (2, 5)
    # -> W1' = (2/2, -3/5) = (1, -0.6), b1' = 1 - 2 * 4/2 - (-3) * 10/5 = 1 - 4 + 6 = 3
    theta = np.zeros(net_size(2))
    theta[0], theta[1], theta[10] = 2.0, -3.0, 1.0
    theta[20] = 0.25  # a later layer's weight: unchanged
    folded = InputScaling((4.0, 10.0), (2.0, 5.0)).fold(theta)
    assert folded[0] == pytest.approx(1.0) and folded[1] == pytest.approx(-0.6)
    assert folded[10] == pytest.approx(3.0)
    assert folded[20] == 0.25 and np.count_nonzero(folded) == 4


def test_folded_net_on_raw_input_gives_the_hand_computed_value():
    # the net of tests/test_decisions.py (value 2.116142 at standardised x = 1.5); mean 10, scale 4:
    # raw x = 10 + 4 * 1.5 = 16; folded W1 = 1/4, b1 = -10/4 -> z = 16/4 - 2.5 = 1.5
    theta = np.zeros(net_size(1))
    theta[0] = 1.0
    theta[5 + 5] = 1.0
    theta[5 + 5 + 25 + 1] = 0.75
    theta[5 + 5 + 25 + 5], theta[5 + 5 + 25 + 5 + 1], theta[5 + 5 + 25 + 5 + 5] = 2.0, -1.0, 0.5
    scaling = InputScaling((10.0,), (4.0,))
    folded = scaling.fold(theta)
    assert (folded[0], folded[5]) == (0.25, -2.5)
    assert net_value(folded, np.array([16.0])) == pytest.approx(2.116142, abs=1e-6)


def test_folded_net_equals_the_net_on_standardised_inputs():
    rng = np.random.default_rng(3)
    scaling = GetOpenScaling().inputs(3, 2, 20.0)
    for theta in rng.standard_normal((20, THETA_SIZE)) * 2.0:
        folded = scaling.fold(theta)
        for x in random_states(rng, 25):
            assert net_value(folded, x) == pytest.approx(net_value(theta, scaling.standardise(x)), abs=1e-9)


def test_identity_fold_is_the_same_net_bit_for_bit():
    theta = np.random.default_rng(0).standard_normal(THETA_SIZE)
    folded = InputScaling.identity(N_INPUTS).fold(theta)
    assert np.array_equal(folded, theta) and folded is not theta


@pytest.mark.parametrize("mean, scale", [((0.0,), (0.0,)), ((0.0,), (-1.0,)), ((np.nan,), (1.0,)),
                                         ((0.0, 1.0), (1.0,)), ((), ())])
def test_input_scaling_refuses_bad_constants(mean, scale):
    with pytest.raises(ValueError, match="input scaling"):
        InputScaling(mean, scale)


def test_fold_refuses_a_net_of_another_size():
    with pytest.raises(ValueError, match="91 parameters"):
        InputScaling.identity(10).fold(np.zeros(90))


# -- the rule ----------------------------------------------------------------------------------------
def test_scaling_rule_for_3v2_on_20_m():
    scaling = GetOpenScaling().inputs(3, 2, 20.0)
    # distances: the table's fraction of the side x 20 m; angles: degrees as they are
    assert scaling.mean == pytest.approx((9.5, 9.5, 8.0, 8.0, 7.96, 7.96, 51.1, 51.1, 9.4, 44.1))
    assert scaling.scale == pytest.approx((4.48, 4.48, 3.74, 3.74, 4.62, 4.62, 44.4, 44.4, 4.4, 38.0))


def test_scaling_rule_gives_every_team_and_field_size_a_scaling():
    # 4v3 on 30 m: 3K + T - 1 = 14 inputs; 3 teammate, 3 taker, 3 teammate-taker distances, 3 angles,
    # the pass distance and the lane angle
    scaling = GetOpenScaling().inputs(4, 3, 30.0)
    assert scaling.n_inputs == 14 == getopen_state_size(4, 3)
    assert scaling.mean[:3] == pytest.approx((14.25,) * 3) and scaling.mean[3:6] == pytest.approx((12.0,) * 3)
    assert scaling.mean[9:12] == pytest.approx((51.1,) * 3) and scaling.scale[9:12] == pytest.approx((44.4,) * 3)
    assert scaling.mean[12:] == pytest.approx((14.1, 44.1))


def test_named_scalings():
    assert getopen_input_scaling(SCALED_INPUTS, 3, 2, 20.0) == GetOpenScaling().inputs(3, 2, 20.0)
    assert getopen_input_scaling(RAW_INPUTS, 3, 2, 20.0) == InputScaling.identity(10)
    with pytest.raises(ValueError, match="scaled, raw"):
        getopen_input_scaling("whitened", 3, 2, 20.0)


# -- ties between grid points ------------------------------------------------------------------------
# keeper 1 at the origin holds the ball (K1); I am keeper 2
TIE_POSITION = [[0.5, 0.0], [0.0, 0.0], [1.0, -2.0], [-5.0, 5.0], [3.0, 3.0], [-3.0, -1.0]]


def saturated_net():
    """Hidden unit 0 = 1.7159 tanh(2/3 (1000 dist(K1, P) - 5000)): exactly +-1.7159 at every grid point
    (none is 5 m from K1), so every point farther than 5 m from K1 has the same, higher value."""
    theta = np.zeros(THETA_SIZE)
    theta[8] = 1000.0  # W1[0, variable 9]
    theta[B1] = -5000.0
    theta[W2] = 1.0
    theta[W3] = 1.0
    return theta


def test_tied_best_points_go_to_the_one_nearest_me_not_the_first_in_scan_order():
    # points > 5 m from the origin, by distance from me (1, -2): (0, -7) 5.10, (3.5, -7) 5.59,
    # (7, -3.5) 6.18, ... The first of them in scan order is the corner (-7, -7), 9.49 from me.
    assert learned_target(belief(TIE_POSITION, 2), 0, saturated_net(), 0, KP, CFG) == pytest.approx((0.0, -7.0))


def test_a_net_without_preference_keeps_me_at_the_nearest_point():
    # all values 0: the nearest grid point to (1, -2) is (0, -3.5) (1.80 m; (0, 0) is 2.24 m)
    assert learned_target(belief(TIE_POSITION, 2), 0, np.zeros(THETA_SIZE), 0, KP, CFG) == pytest.approx((0.0, -3.5))


def test_tie_break_does_not_switch_targets_while_i_walk_to_mine():
    # walking straight to the chosen point shortens my distance to it faster than to any other point
    for t in np.linspace(0.0, 1.0, 11):
        pos = [row[:] for row in TIE_POSITION]
        pos[2] = [1.0 - t, -2.0 - 5.0 * t]
        assert learned_target(belief(pos, 2), 0, saturated_net(), 0, KP, CFG) == pytest.approx((0.0, -7.0))


def test_lane_origin_is_k1_or_the_predicted_ball():
    # ball at (0.5, 0) rolling at (1, 0): after 3 cycles 0.5 + (1 - 0.94^3) / 0.06 = 3.3236
    vel = np.zeros((6, 2))
    vel[0] = [1.0, 0.0]
    bel = belief(TIE_POSITION, 2, vel)
    assert lane_origin(bel, 0, 3, KP, CFG) == pytest.approx((0.0, 0.0))
    predicted = AgentConfig(getopen_lane_from_predicted_ball=True).kernel()
    assert lane_origin(bel, 0, 3, KP, predicted) == pytest.approx((3.3236, 0.0))


# -- policy files ------------------------------------------------------------------------------------
def header_of(path):
    with np.load(path) as data:
        return json.loads(data["header"].tobytes().decode())


def test_policy_file_records_the_input_scaling_and_plays_the_folded_net(tmp_path):
    theta = np.linspace(-1.0, 1.0, THETA_SIZE)
    scaling = GetOpenScaling().inputs(3, 2, 20.0)
    path = save_policy(tmp_path / "p.npz", getopen_theta=theta, getopen_inputs=scaling)
    header = header_of(path)
    assert header["version"] == POLICY_VERSION == 2
    assert header["getopen_inputs"] == {"mean": list(scaling.mean), "scale": list(scaling.scale)}
    policy = load_policy(path)
    np.testing.assert_array_equal(policy.getopen_theta, theta)
    assert policy.getopen_inputs == scaling
    np.testing.assert_array_equal(policy.getopen_net, scaling.fold(theta))


def test_policy_file_without_a_scaling_is_a_net_on_raw_inputs(tmp_path):
    theta = np.linspace(-1.0, 1.0, THETA_SIZE)
    policy = load_policy(save_policy(tmp_path / "p.npz", getopen_theta=theta))
    assert policy.getopen_inputs == InputScaling.identity(10)
    np.testing.assert_array_equal(policy.getopen_net, theta)


def test_version_1_policy_file_loads_with_raw_inputs(tmp_path):
    # written as the program wrote them before input scaling existed
    theta = np.linspace(-1.0, 1.0, THETA_SIZE)
    header = {"format": "keepaway-policy", "version": 1, "config": {"keepers": 3, "takers": 2}, "seed": 0,
              "created": None}
    np.savez(tmp_path / "old.npz", header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8),
             getopen_theta=theta)
    policy = load_policy(tmp_path / "old.npz")
    assert policy.getopen_inputs == InputScaling.identity(10)
    np.testing.assert_array_equal(policy.getopen_net, theta)


@pytest.mark.parametrize("inputs, message", [
    (None, "has no getopen_inputs for getopen_theta"),
    ({"mean": [0.0] * 9, "scale": [1.0] * 9}, "lists of 10 numbers"),
    ({"mean": [0.0] * 10, "scale": [0.0] * 10}, "finite positive scales"),
    ({"mean": [0.0] * 10}, "exactly mean and scale"),
])
def test_bad_input_scaling_in_a_policy_file_is_a_one_line_error(tmp_path, inputs, message):
    header = {"format": "keepaway-policy", "version": 2, "config": {}, "seed": None, "created": None}
    if inputs is not None:
        header["getopen_inputs"] = inputs
    np.savez(tmp_path / "bad.npz", header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8),
             getopen_theta=np.zeros(THETA_SIZE))
    with pytest.raises(PolicyFileError, match=message) as error:
        load_policy(tmp_path / "bad.npz")
    assert "\n" not in str(error.value) and str(error.value).startswith(str(tmp_path / "bad.npz"))


def test_input_scaling_without_a_net_is_refused(tmp_path):
    with pytest.raises(ValueError, match="without getopen_theta"):
        save_policy(tmp_path / "unused.npz", getopen_inputs=InputScaling.identity(10))


# -- the trainer -------------------------------------------------------------------------------------
CONFIG = TrainConfig(pass_policy="handcoded", getopen_policy="learned")


def test_training_searches_nets_on_scaled_inputs_and_plays_them_folded():
    assert CONFIG.getopen_inputs == SCALED_INPUTS
    start = initial_behaviours(CONFIG, 0)
    assert start.getopen_inputs == GetOpenScaling().inputs(3, 2, 20.0)
    np.testing.assert_array_equal(start.getopen_net, start.getopen_inputs.fold(start.getopen_theta))
    advice = policy_advice(start)[0][1]
    np.testing.assert_array_equal(np.frombuffer(advice.to_wire()["getopen_theta"], dtype="<f8"), start.getopen_net)


def test_training_begun_before_scaling_resumes_with_raw_inputs():
    stored = CONFIG.to_dict()
    del stored["getopen_inputs"]
    assert TrainConfig.from_dict(stored).input_scaling() == InputScaling.identity(10)
    assert TrainConfig.from_dict(CONFIG.to_dict()) == CONFIG
    with pytest.raises(ValueError, match="GetOpen inputs"):
        TrainConfig(pass_policy="handcoded", getopen_policy="learned", getopen_inputs="whitened")


def test_checkpoint_and_policy_file_keep_the_scaling(tmp_path):
    state = TrialState(0, initial_behaviours(CONFIG, 0), curve=[CurvePoint(0, 5.0, 0.1)])
    trial_dir(tmp_path, 0).mkdir()
    save_checkpoint(tmp_path, state)
    restored = load_checkpoint(tmp_path, 0)
    assert restored.behaviours.getopen_inputs == state.behaviours.getopen_inputs
    np.testing.assert_array_equal(restored.behaviours.getopen_net, state.behaviours.getopen_net)
    write_trial_outputs(CONFIG, tmp_path, state)
    policy = load_policy(trial_dir(tmp_path, 0) / "policy.npz")
    assert policy.getopen_inputs == state.behaviours.getopen_inputs
    np.testing.assert_array_equal(policy.getopen_net, state.behaviours.getopen_net)
