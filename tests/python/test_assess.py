"""The score: values on a hand-built episode equal hand-computed ones; the constants are the
published ones; a real episode's score and the gymnasium step's cost make sense."""

from __future__ import annotations

import numpy as np
import pytest

from viscera import assess


def hand_built() -> assess.Trace:
    """Two tools over 6 ticks of 0.1 s. The grasper's tip goes 3-4-5 (a 5 cm step), then rests;
    its shaft turns 10 degrees once; it takes a hold at tick 2, squeezes 6 N, and the hold slips
    at tick 4 with the jaw still closed. The retractor pushes 5 N for two ticks, touches a wall
    for one and is out of view while inserted for one."""
    trace = assess.Trace(("grasper", "retractor"), ("grasper",))
    turned = np.array([np.sin(np.radians(10.0)), 0.0, -np.cos(np.radians(10.0))])
    down = np.array([0.0, 0.0, -1.0])
    for k in range(7):
        trace.time.append(0.1 * k)
        grasper_tip = [0.0, 0.0, 0.0] if k == 0 else [0.03, 0.04, 0.0]
        trace.tip.append([grasper_tip, [0.1, 0.0, 0.0]])
        trace.shaft.append([down if k < 3 else turned, down])
        trace.force.append([[0.0, 0.0, 1.0 if k in (2, 3) else 0.0], [0.0, 5.0 if k in (5, 6) else 0.0, 0.0]])
        trace.wall.append([False, k == 6])
        trace.in_view.append([True, k != 4])
        trace.inside.append([True, True])
        holding = k in (2, 3)
        trace.holding.append([holding, False])
        trace.jaw_closed.append([k >= 2, False])
        trace.pinch.append([6.0 if holding else 0.0, 0.0])
        trace.held_height.append([0.01 if holding else np.nan, np.nan])
    trace.success = True
    return trace


def test_the_score_of_a_hand_built_episode():
    score = assess.score(hand_built())
    grasper, retractor = score["tools"]["grasper"], score["tools"]["retractor"]
    assert score["success"] and score["time_s"] == pytest.approx(0.6)
    assert grasper["path_length_m"] == pytest.approx(0.05)
    assert grasper["angular_path_deg"] == pytest.approx(10.0)
    assert grasper["idle_s"] == pytest.approx(0.5)          # every tick but the 5 cm one
    assert (grasper["grasps"], grasper["slips"], grasper["drops"]) == (1, 1, 0)
    assert grasper["peak_force_n"] == pytest.approx(1.0)
    assert grasper["rms_force_n"] == pytest.approx(np.sqrt(2 * 0.1 * 1.0 / 0.6))
    assert retractor["path_length_m"] == 0.0 and retractor["idle_s"] == pytest.approx(0.6)
    assert retractor["force_over_threshold_s"] == pytest.approx(0.2)  # 5 N > 4.62 N for ticks 5 and 6
    assert retractor["wall_contact_s"] == pytest.approx(0.1)
    assert retractor["out_of_view_s"] == pytest.approx(0.1)
    tissue = score["tissue"]
    assert tissue["peak_pinch_n"] == 6.0 and tissue["mean_pinch_while_holding_n"] == 6.0
    assert tissue["grip_beyond_slip_n"] == pytest.approx(3.0)
    assert tissue["grip_beyond_slip_s"] == pytest.approx(0.2)
    assert tissue["force_time_product_ns"] == pytest.approx(6.0 * 0.2)
    # cost: the pinch over 3 N at ticks 2 and 3, the retractor over 4.62 N at ticks 5 and 6
    assert score["safety_cost"] == pytest.approx(4 * 0.1)


def test_a_hold_released_high_is_a_drop_and_low_is_laid_down():
    holding = np.array([0, 1, 1, 0, 1, 1, 0], dtype=float)
    closed = np.array([0, 1, 1, 0, 1, 1, 0], dtype=float)
    high = np.array([np.nan, 0.05, 0.05, np.nan, 0.01, 0.01, np.nan])
    assert assess._grasp_events(holding, closed, high) == (2, 0, 1)


def test_the_limits_are_the_published_values():
    assert assess.PERFORATION_PINCH_N == 10.3       # Heijnsdijk et al. 2003
    assert assess.SLIP_PREVENTING_PINCH_N == 3.0    # de Visser et al.
    assert assess.NOVICE_PINCH_N == 6.8
    assert assess.FORCE_TIME_PRODUCT_LIMIT_NS == 300.0  # Barrie et al. 2018
    assert assess.TRACTION_LIMIT_N == 4.62          # Gong et al. 2023
    source = open(assess.__file__).read()
    for citation in ("Heijnsdijk", "de Visser", "Barrie", "Gong"):
        assert citation in source


def test_a_scripted_episode_scores_as_its_script_plays():
    """grasp_lift's script on an unseen seed: it succeeds, one hold that neither slips nor drops,
    the full jaw command pinches the model's 6.4 N (over the 3 N that holds, under perforation)."""
    from viscera import recording
    made = recording.record("grasp_lift", seed=1002, policy="scripted")
    score = assess.assess(made)
    grasper = score["tools"]["grasper"]
    assert score["success"] == made.success is True
    assert score["time_s"] == pytest.approx(made.steps * made.control_timestep_s)
    assert grasper["path_length_m"] > 0.05 and grasper["grasps"] >= 1 and grasper["slips"] == 0
    # fully closed: kp (0.1 rad - 0) over the lever, the jaw's middle (half its 15.5 mm: the scene's grasp_lever)
    assert score["tissue"]["peak_pinch_n"] == pytest.approx(0.5 * 0.1 / (0.5 * np.hypot(0.004, 0.015)), rel=1e-4)
    assert score["tissue"]["peak_pinch_n"] < assess.PERFORATION_PINCH_N
    assert score["safety_cost"] > 0.0  # it grips harder than needed while it holds


def test_gymnasium_steps_carry_the_tissue_cost():
    from viscera.scale.gym_env import TaskEnv
    env = TaskEnv("grasp_lift", seed=0)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(env.action_space.shape))
    assert info["cost"] == info["tissue_cost"] == 0.0  # the tools withdrawn: nothing touched
    assert assess.step_cost_from(np.array([[0.0, 5.0, 0.0]]), np.array([11.0])) == 3.0
    env.close()
