"""The reward contract (viscera.tasks.reward): success is the return's optimum on every task.

Proved from each task's declared bounds, then checked on episodes: the scripted policy's rewards
sum to what the contract says, and adversaries on the same seed (stopping short, letting go at the
last moment, stirring so that nothing stays still) return less than it.
"""

import math

import numpy as np
import pytest

import viscera.tasks
from viscera.tasks import reward

SEED = 1000  # the first of the evaluation seeds (docs/tasks/rates.json): the scripted policy succeeds on it


def scripted_episode(name: str, **options):
    """The scripted policy's episode on SEED: (actions, rewards, success step or None, Phi(s_0), env)."""
    env = viscera.tasks.load(name, seed=SEED, **options)
    policy = viscera.tasks.scripted_policy(env)
    step = env.reset()
    start = env.task.potential(env.physics)
    actions, rewards, success_step = [], [], None
    while not step.last():
        actions.append(policy(step))
        step = env.step(actions[-1])
        rewards.append(step.reward)
        if success_step is None and env.task.success(env.physics):
            success_step = len(rewards)
    return np.array(actions), np.array(rewards), success_step, start, env


@pytest.fixture(scope="module")
def scripted():
    return {name: scripted_episode(name) for name in viscera.tasks.ALL}


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_the_contract_is_proved_from_each_tasks_bounds(name):
    """From the task's bounds alone (potential in [0, 1], time cost, bonus, step limit): a success at
    any step returns more than one a step later and more than any episode without success, from
    any start."""
    env = viscera.tasks.load(name)
    contract = env.task.contract
    assert contract.proof() == []
    assert contract.steps == round(env.time_limit_s / env.control_timestep())
    assert contract.time_cost * contract.steps == pytest.approx(1.0)  # a whole default episode costs 1
    steps = np.arange(1, int(contract.steps) + 1)
    for start in (0.0, 0.5, 1.0):
        returns = np.array([contract.success_return(k, start) for k in steps])
        assert np.all(np.diff(returns) < 0.0)  # sooner beats later
        assert returns.min() > contract.best_return_without_success(start)
    # a contract that would not hold is refused: no time cost, or no step limit
    assert reward.Contract(time_cost=0.0, steps=100).proof()
    assert reward.Contract(time_cost=0.01, steps=math.inf).proof()


@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_a_scripted_episode_returns_what_the_contract_says(name, scripted):
    """Each step's reward within the declared bounds; the return exactly the contract's for a
    success at that step (the potential's changes telescope)."""
    actions, rewards, success_step, start, env = scripted[name]
    contract = env.task.contract
    assert success_step == len(rewards)  # it succeeded, and that ended the episode
    low, high = contract.step_bounds()
    assert np.all((rewards[:-1] >= low) & (rewards[:-1] <= high))
    low, high = contract.success_bounds()
    assert low <= rewards[-1] <= high
    assert rewards.sum() == pytest.approx(contract.success_return(success_step, start), abs=1e-9)


def adversary(name: str, actions: np.ndarray, success_step: int, kind: str):
    """The scripted actions up to half a second before the condition began to hold for its lasting
    success, then:
    - "stop_short": the last command held (hovering just short of the goal),
    - "let_go": every jaw opened at the last moment (the tissue dropped),
    - "stir": the tools kept moving, a sway of 6 degrees at 1 Hz about the last command, so that
      a condition asking for still tools never holds;
    to the episode's end. Returns (return, the step it succeeded at or None, the contract)."""
    env = viscera.tasks.load(name, seed=SEED)
    spec = env.action_spec()
    names = [env.physics.model.id2name(i, "actuator") for i in range(env.physics.model.nu)]
    onset = success_step - int(round(env.task.HOLD_S / env.control_timestep()))
    cut = onset - int(round(0.5 / env.control_timestep()))
    step, total, steps, success_at = env.reset(), 0.0, 0, None
    held = actions[cut - 1].copy()
    while not step.last():
        if steps < cut:
            action = actions[steps]
        else:
            action = held.copy()
            if kind == "let_go":
                action[[i for i, n in enumerate(names) if n.endswith("_jaw")]] = spec.maximum[
                    [i for i, n in enumerate(names) if n.endswith("_jaw")]]
            elif kind == "stir":
                sway = np.radians(6.0) * math.sin(2.0 * math.pi * (steps - cut) * env.control_timestep())
                pivots = [i for i, n in enumerate(names) if n.endswith(("_pitch", "_yaw"))]
                action[pivots] = np.clip(held[pivots] + sway, spec.minimum[pivots], spec.maximum[pivots])
        step = env.step(action)
        total += step.reward
        steps += 1
        if success_at is None and env.task.success(env.physics):
            success_at = steps
    return total, success_at, env.task.contract


@pytest.mark.parametrize("kind", ["stop_short", "let_go", "stir"])
@pytest.mark.parametrize("name", viscera.tasks.ALL)
def test_adversaries_return_less_than_the_scripted_success(name, kind, scripted):
    """An adversary that follows the script almost to its success and then does not succeed returns
    less than the script, and no more than the contract's best without success; one that still
    succeeds is paid exactly the contract's return for its step, more than the script's only if
    it succeeded sooner."""
    actions, rewards, success_step, start, _ = scripted[name]
    total, success_at, contract = adversary(name, actions, success_step, kind)
    if success_at is None:
        assert total < rewards.sum()
        assert total <= contract.best_return_without_success(start) + 1e-9
    else:
        assert total == pytest.approx(contract.success_return(success_at, start), abs=1e-9)
        assert (total < rewards.sum()) == (success_at > success_step)
    ADVERSARIES_THAT_FAILED.setdefault(name, []).append(success_at is None)


ADVERSARIES_THAT_FAILED: dict[str, list[bool]] = {}


def test_every_task_met_an_adversary_that_did_not_succeed():
    """The adversaries above are not idle: on every task at least one of them kept success away
    (so the comparison without success was made)."""
    if set(ADVERSARIES_THAT_FAILED) != set(viscera.tasks.ALL) or any(len(v) != 3 for v in ADVERSARIES_THAT_FAILED.values()):
        pytest.skip("runs after the adversaries' test, in the same session")
    assert all(any(failed) for failed in ADVERSARIES_THAT_FAILED.values()), ADVERSARIES_THAT_FAILED


@pytest.mark.parametrize("name", ["grasp_lift", "run_the_bowel"])
def test_sparse_pays_success_alone_and_changes_nothing_else(name, scripted):
    """reward="sparse": 1 on the step success first holds, 0 on every other; the episode itself
    (every action's outcome, the final state) is the dense one's, bit for bit."""
    actions, dense_rewards, success_step, _, dense_env = scripted[name]
    env = viscera.tasks.load(name, seed=SEED, reward="sparse")
    step = env.reset()
    rewards = []
    for action in actions:
        step = env.step(action)
        rewards.append(step.reward)
    assert step.last() and len(rewards) == success_step
    assert rewards == [0.0] * (success_step - 1) + [1.0]
    from viscera.recording import final_state_sha256
    assert final_state_sha256(env.physics) == final_state_sha256(dense_env.physics)


def test_a_success_that_does_not_end_the_episode_is_paid_once():
    """clear_area with end_on_success=False: the bonus on the first step of lasting success only."""
    actions, rewards, success_step, _, _ = scripted_episode("clear_area")
    env = viscera.tasks.load("clear_area", seed=SEED, end_on_success=False)
    step, paid = env.reset(), []
    policy = viscera.tasks.scripted_policy(env)
    for _ in range(success_step + 25):
        step = env.step(policy(step))
        paid.append(step.reward > 0.5)  # a bonus step pays at least S - c
    assert sum(paid) == 1 and paid.index(True) == success_step - 1


def test_a_bad_reward_kind_is_refused_by_name():
    with pytest.raises(ValueError, match=r"^reward = 'shaped': must be one of 'dense', 'sparse'$"):
        viscera.tasks.load("grasp_lift", reward="shaped")


def test_the_task_page_states_each_tasks_bounds():
    """docs/tasks.md's table gives each task's time cost, step limit and reward bounds as the code has them."""
    import pathlib
    page = (pathlib.Path(__file__).resolve().parents[2] / "docs" / "tasks.md").read_text()
    for name in viscera.tasks.ALL:
        contract = viscera.tasks.load(name).task.contract
        row = next(line for line in page.splitlines() if line.startswith(f"| `{name}` | ") and "1/" in line)
        cells = [cell.strip() for cell in row.split("|")[1:-1]]
        steps = int(contract.steps)
        assert cells[2:4] == [f"1/{steps}", str(steps)]
        assert cells[4] == "{:.4f} to {:.4f}".format(*contract.step_bounds()).replace("-", "−")
        assert cells[5] == "{:.4f} to {:.4f}".format(*contract.success_bounds())
