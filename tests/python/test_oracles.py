"""The scripted oracles (viscera.tasks.oracle): each control step's decision (action, phase, lead
tool, aims) is a function of the observation alone, so a fresh oracle handed any state of an
episode decides as the one that played it; handed a perturbed episode mid-way, a fresh oracle
finishes it; and its decision packs into the labels the datasets write."""

import numpy as np
import pytest

import viscera.tasks

# control steps played per task: past a grasp into what follows it (a lift, a carry, a hand-over
# of the bowel), cheap on CI (clear_area's steps cost the most: its carry predictions)
STEPS = {"clear_area": 150, "grasp_lift": 150, "retract_reach": 300, "run_the_bowel": 300}


def assert_same_decision(got, want, where: str):
    """Bit for bit: the action, the phase, the lead tool and every tool's aim."""
    assert np.array_equal(got.action, want.action), where
    assert (got.phase, got.lead) == (want.phase, want.lead), where
    assert sorted(got.aims) == sorted(want.aims), where
    for tool in want.aims:
        assert np.array_equal(got.aims[tool], want.aims[tool]), f"{where}: {tool}'s aim"


def test_every_task_has_an_oracle_and_names_its_phases():
    for name in viscera.tasks.ALL:
        oracle = viscera.tasks.scripted_policy(viscera.tasks.load(name, seed=0))
        assert viscera.tasks.oracle_phases(name) == type(oracle).PHASES and len(oracle.PHASES) > 0
        assert oracle.phase == "-" and oracle.last is None  # no decision yet
    with pytest.raises(KeyError, match="unknown task 'nope'"):
        viscera.tasks.oracle_phases("nope")


@pytest.mark.parametrize("task", viscera.tasks.ALL)
def test_a_fresh_oracle_decides_as_the_one_that_played_the_episode(task):
    """The scripted oracle plays the start of an episode; at every step an oracle built anew, on
    another environment of the same task and seed that never left its reset (so it can read
    nothing of the episode but the observation it is handed), decides the same action, phase,
    lead tool and aims, bit for bit. The episode gets through several phases, so the hand-offs
    between them (which a timed plan would carry in memory) are decided from the state too.
    Each decision packs into the dataset labels: [phase index, lead tool index, aims]."""
    env = viscera.tasks.load(task, seed=0)
    other = viscera.tasks.load(task, seed=0)
    other.reset()
    oracle = viscera.tasks.scripted_policy(env)
    time_step = env.reset()
    phases = []
    for step in range(STEPS[task]):
        if time_step.last():
            break
        action = oracle(time_step)
        decision = oracle.last
        assert action is decision.action and decision.phase in oracle.PHASES and decision.lead in oracle.names
        assert sorted(decision.aims) == sorted(oracle.names)  # every tool aims somewhere (a still one: where it is)
        assert all(np.asarray(decision.aims[t]).shape == (3,) and np.all(np.isfinite(decision.aims[t]))
                   for t in oracle.names)
        assert np.all(np.isfinite(action)) and action.shape == env.action_spec().shape
        fresh = viscera.tasks.scripted_policy(other)
        assert_same_decision(fresh.decide(time_step.observation), decision, f"{task} step {step}")
        vector = decision.vector(oracle.PHASES, oracle.names)
        assert vector.shape == (2 + 3 * len(oracle.names),)
        assert vector[0] == oracle.PHASES.index(decision.phase) and vector[1] == oracle.names.index(decision.lead)
        assert np.array_equal(vector[2:], np.concatenate([decision.aims[t] for t in oracle.names]))
        if not phases or phases[-1] != decision.phase:
            phases.append(decision.phase)
        time_step = env.step(action)
    assert len(set(phases)) >= 4, phases  # approach, descend, close and what follows the grasp, at least


# (task, seed, when the fresh oracle takes over, s): mid-way through each seed's noisy episode,
# two points for the cheap tasks; seeds where the hand-over succeeds (python/tools/task_rates.py
# --handover measures the rates over 100 seeds)
HANDOVERS = [("grasp_lift", 0, 0.9), ("grasp_lift", 0, 1.8), ("run_the_bowel", 0, 3.0), ("run_the_bowel", 0, 6.0),
             ("retract_reach", 0, 3.3), ("clear_area", 2, 9.36)]


@pytest.mark.parametrize("task, seed, handover_s", HANDOVERS)
def test_a_fresh_oracle_finishes_a_perturbed_episode(task, seed, handover_s):
    """The scripted oracle plays with Gaussian noise of 2 % of each actuator's range added to every
    action (the tools off its course, its commands off its last decisions), then an oracle built
    anew takes over the state as it is, with nothing but the observation, and succeeds. The same
    episode as the rates tool's hand-over measurement (python/tools/task_rates.py's episode)."""
    import task_rates  # python/tools, importable from the tests (conftest.py)
    result = task_rates.episode(task, seed, "scripted", handover_s=handover_s)
    assert result["simulated_s"] > handover_s + 0.01, result  # handed over mid-way, not after the episode ended
    assert result["success"], result


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_an_oracle_reading_what_it_meant_to_send_bears_noise_throughout(seed):
    """Under Gaussian noise of 2 % of each actuator's range on every action of the episode, the
    grasp_lift oracle succeeds when it reads back the command it meant to send: its tests on its own
    last command (a jaw within 0.5 degree of open, a tip within 5 mm of where it was sent) then see
    no noise, and the physics' perturbation is left to its feedback. Reading the executed command
    (noise and all), it succeeds on 13 of seeds 1000-1099 (python/tools/task_rates.py --noisy). DAgger
    with noise (python/tools/learning/bc.py --dagger-noise) labels the way that succeeds."""
    import task_rates
    result = task_rates.episode("grasp_lift", seed, "scripted", noisy="intended")
    assert result["success"], result
