"""Bad input to any command is refused before anything starts, with one line saying what is wrong and
what is allowed: no traceback, exit code 2 for a usage error, and nothing on disk changed."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import keepaway_command
from keepaway.agents.policy_file import getopen_theta_size, save_policy

QUICK_S = 120  # a refusal comes before any kernel is compiled or any process started
PLAYING_S = 900  # an evaluation that plays (it may have to compile the batched kernels first)
FREE_PORTS = ("--players-port", "0", "--coach-port", "0", "--monitor-port", "0")
CLICK_LINES = ("Usage:", "Try '")  # click's reminder above a usage error's one line


def refused(processes, *args: str, code: int = 2, timeout_s: float = QUICK_S) -> str:
    """Run ``keepaway *args``; check it exits with ``code`` saying one line and no traceback; return the
    line."""
    proc = processes.popen(keepaway_command(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, err_bytes = proc.communicate(timeout=timeout_s)
    err = err_bytes.decode()
    assert proc.returncode == code, err
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith(CLICK_LINES)]
    assert len(lines) == 1, err
    assert err.rstrip().splitlines()[-1] == lines[0]
    return lines[0]


def test_the_command_line_loads_without_numba_so_usage_errors_come_at_once(processes):
    """Loading numba takes a third of a second or more: ``keepaway --help`` and every refusal before
    anything plays must not pay it (each package's cli imports its kernels only inside commands)."""
    probe = ("import sys, keepaway.cli; "
             "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'llvmlite')))")
    proc = processes.popen([sys.executable, "-c", probe], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=QUICK_S)
    assert proc.returncode == 0, err.decode()
    assert out.decode().strip() == "[]"


@pytest.fixture
def policy_files(tmp_path):
    """Files that are not keepaway policies: random bytes, a plain numpy archive, a truncated real
    policy file, a single .npy array."""
    real = save_policy(tmp_path / "real.npz", getopen_theta=np.zeros(getopen_theta_size()),
                       config={"pass": "handcoded", "getopen": "learned"})
    files = {"random": tmp_path / "random.npz", "plain": tmp_path / "plain.npz",
             "truncated": tmp_path / "truncated.npz", "npy": tmp_path / "array.npz"}
    files["random"].write_bytes(np.random.default_rng(1).bytes(500))
    np.savez(files["plain"], weights=np.zeros(3))
    files["truncated"].write_bytes(real.read_bytes()[: real.stat().st_size // 2])
    np.save(tmp_path / "array.npy", np.zeros(3))
    (tmp_path / "array.npy").rename(files["npy"])
    return files


# -- keepaway run: teams, seeds, the region and policy files ---------------------------------------
@pytest.mark.parametrize("args, problem", [
    (["--keepers", "1", "--takers", "0"], "Invalid value for '--keepers': 1 is not in the range 2<=x<=11."),
    (["--keepers", "12"], "Invalid value for '--keepers': 12 is not in the range 2<=x<=11."),
    (["--takers", "0"], "Invalid value for '--takers': 0 is not in the range 1<=x<=11."),
    (["--seed", "-1"], "Invalid value for '--seed': -1 is not in the range 0<=x<=9223372036854775807."),
    (["--field-size", "-3"], "Invalid value for '--field-size': -3.0 is not in the range x>0.0."),
    (["--field-size", "100"], "Invalid value for '--field-size': a square region of side 100 m does not fit the "
                              "pitch (105 x 68 m): its side must be above 0 and at most 68 m"),
    (["--field-size", "nan"], "Invalid value for '--field-size': nan is not a finite number"),
    (["--field-size", "inf"], "Invalid value for '--field-size': inf is not a finite number"),
])
def test_run_refuses_teams_seeds_and_regions_outside_their_ranges_before_starting(processes, tmp_path, args,
                                                                                  problem):
    out = tmp_path / "out"
    assert refused(processes, "run", *args, "--out", str(out)) == f"Error: {problem}"
    assert not out.exists()  # no server, coach or player was started


@pytest.mark.parametrize("kind, problem", [
    ("random", "not a readable policy archive (not an .npz archive: another kind of file, or a truncated one)"),
    ("plain", "not a keepaway policy file: no header array (it holds weights)"),
    ("truncated", "not a readable policy archive (not an .npz archive: another kind of file, or a truncated one)"),
    ("npy", "not a readable policy archive (a single .npy array, not an .npz archive)"),
])
def test_a_file_that_is_not_a_keepaway_policy_is_named_with_its_problem(processes, tmp_path, policy_files, kind,
                                                                       problem):
    path = policy_files[kind]
    line = refused(processes, "run", "--getopen", "learned", "--policy", str(path), "--out", str(tmp_path / "o"))
    assert line == f"Error: {path}: {problem}"
    line = refused(processes, "player", "--team", "keepers", "--getopen", "learned", "--policy", str(path))
    assert line == f"keepaway player: {path}: {problem}"
    line = refused(processes, "evaluate", "--policy", str(path), timeout_s=PLAYING_S)  # kernels first
    assert line == f"Error: {path}: {problem}"


def test_a_directory_given_as_a_policy_file_is_refused(processes, tmp_path):
    line = refused(processes, "run", "--policy", str(tmp_path), "--out", str(tmp_path / "o"))
    assert line == f"Error: Invalid value for '--policy': File '{tmp_path}' is a directory."
    empty = tmp_path / "empty"
    empty.mkdir()
    assert refused(processes, "evaluate", "--policy", str(empty)) == (
        f"Error: {empty}: no policy files (trial_*/policy.npz or *.npz)")


@pytest.mark.parametrize("command", ["run", "train"])
def test_a_ray_address_without_the_ray_backend_is_refused_not_ignored(processes, tmp_path, command):
    line = refused(processes, command, "--mode", "distributed", "--ray-address", "auto", "--out", str(tmp_path / "o"))
    assert line == "Error: --ray-address names the Ray cluster of --backend ray: add --backend ray or leave it out"
    assert not (tmp_path / "o").exists()


# -- keepaway server: flags, parameters and TOML files ---------------------------------------------
@pytest.mark.parametrize("args, problem", [
    (["--seed", "-1"], "Invalid value for '--seed': -1 is not in the range 0<=x<=9223372036854775807."),
    (["--field-size", "-3"], "Invalid value for '--field-size': -3.0 is not in the range x>0.0."),
    (["--keepers", "0"], "Invalid value for '--keepers': 0 is not in the range 1<=x<=11."),
    (["--players-port", "70000"], "Invalid value for '--players-port': 70000 is not in the range 0<=x<=65535."),
    (["--field-size", "70"], "Invalid value for '--field-size': a square region of side 70 m does not fit the "
                             "pitch (105 x 68 m): its side must be above 0 and at most 68 m"),
    (["--field-size", "nan"], "Invalid value for '--field-size': nan is not a finite number"),
    (["--param", "pitch_width=50", "--field-size", "60"],
     "Invalid value for '--field-size': a square region of side 60 m does not fit the pitch (105 x 50 m): its side "
     "must be above 0 and at most 50 m"),
    (["--cycle-timeout", "0"], "Invalid value for '--cycle-timeout': 0.0 is not in the range x>0.0."),
    (["--cycle-timeout", "nan"], "Invalid value for '--cycle-timeout': nan is not a finite number"),
    (["--max-cycles", "-5"], "Invalid value for '--max-cycles': -5 is not in the range x>=1."),
    (["--param", "ball_decay=-0.5"], "server parameter ball_decay=-0.5 is out of range: allowed [0, 1]"),
    (["--param", "effort_dec=-0.1"], "server parameter effort_dec=-0.1 is out of range: allowed [0, 1]"),
    (["--param", "simulator_step_ms=0"], "server parameter simulator_step_ms=0.0 is out of range: allowed (0, inf)"),
    (["--param", "min_dash_power=200"], "server parameter min_dash_power=200.0 must not exceed max_dash_power=100.0"),
    (["--host", ""], "host = '' is not a non-empty string"),
])
def test_server_refuses_nonsensical_values_instead_of_starting(processes, args, problem):
    assert refused(processes, "server", *FREE_PORTS, *args) == f"Error: {problem}"


@pytest.mark.parametrize("toml, problem", [
    ('seed = "abc"', "seed = 'abc' is not an integer"),
    ("seed = -1", "seed = -1 is out of range: allowed [0, 9223372036854775807]"),
    ("episodes = 1.5", "episodes = 1.5 is not an integer"),
    ("keepers = true", "keepers = True is not an integer"),
    ("log_dir = 5", "log_dir = 5 is not a path"),
    ('mode = "fast"', "mode = 'fast' is out of range: allowed {sync, realtime}"),
    ("params = 3", "params = 3 is not a table ([params] with NAME = VALUE lines)"),
    ('[params]\nball_decay = "x"', "[params] server parameter ball_decay='x' is not a number"),
    ("[params]\nball_decay = 2.0", "[params] server parameter ball_decay=2.0 is out of range: allowed [0, 1]"),
    ("[params]\nwarp = 1", "[params] unknown server parameter 'warp'"),
    ("[params]\nname = 4", "[params] name: choose the set with parameter_set at the top level"),
    ('parameter_set = "old"', "parameter_set = 'old' is not one of classic, current"),
    ("max_message_bytes = 1099511627776",
     "max_message_bytes = 1099511627776 is out of range: allowed [1024, 67108864]"),
    ("coach_budget = 0", "coach_budget = 0 is out of range: allowed [1, inf)"),
])
def test_a_toml_value_of_the_wrong_type_or_range_names_the_file_key_and_value(processes, tmp_path, toml, problem):
    config = tmp_path / "server.toml"
    config.write_text(toml + "\n")
    assert refused(processes, "server", *FREE_PORTS, "--config", str(config)) == f"Error: {config}: {problem}"


def test_unknown_toml_settings_are_named_with_the_known_ones(processes, tmp_path):
    config = tmp_path / "server.toml"
    config.write_text("warp = 1\n")
    line = refused(processes, "server", *FREE_PORTS, "--config", str(config))
    assert (line.startswith(f"Error: {config}: unknown setting(s) warp; known: coach_budget, coach_port, ")
            and "seed" in line)


# -- keepaway player and coach ---------------------------------------------------------------------
@pytest.mark.parametrize("command, args, problem", [
    ("player", ["--team", "keepers", "--seed", "-1"],
     "Invalid value for '--seed': -1 is not in the range 0<=x<=9223372036854775807."),
    ("player", ["--team", "keepers", "--connect-timeout", "0"],
     "Invalid value for '--connect-timeout': 0.0 is not in the range x>0.0."),
    ("coach", ["--server", "foo"], "Invalid value for --server: not a tcp:// endpoint: 'foo'"),
    # a negative timeout used to make the coach wait for ever
    ("coach", ["--server", "tcp://127.0.0.1:1", "--connect-timeout", "-1"],
     "Invalid value for '--connect-timeout': -1.0 is not in the range x>0.0."),
    ("coach", ["--server", "tcp://127.0.0.1:1", "--arena-port", "70000"],
     "Invalid value for '--arena-port': 70000 is not in the range 0<=x<=65535."),
    ("coach", ["--server", "tcp://127.0.0.1:1", "--episodes", "0"],
     "Invalid value for '--episodes': 0 is not in the range x>=1."),
])
def test_player_and_coach_refuse_bad_options(processes, command, args, problem):
    assert refused(processes, command, *args) == f"Error: {problem}"


# -- keepaway train, evaluate and experiment -------------------------------------------------------
@pytest.mark.parametrize("args, problem", [
    (["--keepers", "1"], "Invalid value for '--keepers': 1 is not in the range 2<=x<=11."),
    (["--takers", "0"], "Invalid value for '--takers': 0 is not in the range 1<=x<=11."),
    (["--seed", "-1"], "Invalid value for '--seed': -1 is not in the range 0<=x<=9223372036854775807."),
    (["--field-size", "-3"], "Invalid value for '--field-size': -3.0 is not in the range x>0.0."),
    (["--field-size", "80"], "Invalid value for '--field-size': a square region of side 80 m does not fit the "
                             "pitch (105 x 68 m): its side must be above 0 and at most 68 m"),
    (["--field-size", "inf"], "Invalid value for '--field-size': inf is not a finite number"),
    (["--threads", "0"], "Invalid value for '--threads': 0 is not in the range x>=1."),
    (["--episodes", "-5"], "Invalid value for '--episodes': -5 is not in the range x>=1."),
    (["--arenas", "3"], "--arenas counts the distributed mode's arenas of processes; the batched mode plays each "
                        "chunk of 25 episodes in an arena of its own: leave it out"),
])
def test_train_refuses_bad_options_before_writing_anything(processes, tmp_path, args, problem):
    out = tmp_path / "train"
    assert refused(processes, "train", *args, "--out", str(out), "--no-progress") == f"Error: {problem}"
    assert not out.exists()


@pytest.mark.parametrize("command, args, problem", [
    ("evaluate", ["--policy", ".", "--seed", "-1"],
     "Invalid value for '--seed': -1 is not in the range 0<=x<=9223372036854775807."),
    ("evaluate", ["--policy", ".", "--arenas", "0"], "Invalid value for '--arenas': 0 is not in the range x>=1."),
    ("experiment", ["figure3", "--seed", "-1"],
     "Invalid value for '--seed': -1 is not in the range 0<=x<=9223372036854775807."),
    ("experiment", ["table2", "--threads", "0"], "Invalid value for '--threads': 0 is not in the range x>=1."),
])
def test_evaluate_and_experiment_refuse_bad_options(processes, tmp_path, command, args, problem):
    assert refused(processes, command, *args) == f"Error: {problem}"


@pytest.fixture
def training(tmp_path):
    """A training directory as ``keepaway train`` leaves it after its first step (P:HC-GO:L, one trial)."""
    from keepaway.trainer.cem import CEMConfig
    from keepaway.trainer.schedule import GETOPEN, Phase
    from keepaway.trainer.train import (
        TrainConfig,
        TrialState,
        initial_behaviours,
        save_checkpoint,
        trial_dir,
        write_config,
    )

    config = TrainConfig("handcoded", "learned", (Phase(GETOPEN, 50),), eval_every=50, eval_episodes=2, arenas=2,
                         cem=CEMConfig(n_params=getopen_theta_size(), population=2, elite=1,
                                       episodes_per_candidate=25))
    out = tmp_path / "training"
    write_config(config, out)
    trial_dir(out, 0).mkdir()
    save_checkpoint(out, TrialState(0, initial_behaviours(config, 0), episodes=50))
    return out


def damage_checkpoint_by_truncating(path):
    path.write_bytes(path.read_bytes()[:300])
    return "not an .npz archive: another kind of file, or a truncated one"


def damage_checkpoint_by_overwriting(path):
    np.savez(path, header=np.frombuffer(b'{"version": 1, "trial": 0}', dtype=np.uint8))
    return "no 'pass_policy'"


@pytest.mark.parametrize("damage", [damage_checkpoint_by_truncating, damage_checkpoint_by_overwriting])
def test_resume_from_a_damaged_checkpoint_names_it_and_the_way_out(processes, training, damage):
    checkpoint = training / "trial_000" / "checkpoint.npz"
    reason = damage(checkpoint)
    before = checkpoint.read_bytes()
    line = refused(processes, "train", "--resume", str(training), "--no-progress")
    assert line == (f"Error: {checkpoint}: unusable checkpoint ({reason}); restore it from a copy, or delete it to "
                    f"play trial 0 again from its start (the other trials are kept)")
    assert checkpoint.read_bytes() == before


@pytest.mark.parametrize("edit, reason", [
    (lambda text: "{", "Expecting property name"),
    (lambda text: json.dumps({**json.loads(text), "trials": "2"}), "trials is '2', expected an integer"),
    (lambda text: json.dumps({**json.loads(text), "warp": 1}), "unknown setting(s) warp"),
    (lambda text: "[1, 2]", "not a JSON object"),
    (lambda text: json.dumps({k: v for k, v in json.loads(text).items() if k != "chunk_episodes"}),
     "begun by the batched mode before it played chunks as the other modes do: resumed now it would go on with "
     "other games"),
])
def test_resume_with_a_damaged_configuration_names_it_and_the_way_out(processes, training, edit, reason):
    config = training / "config.json"
    config.write_text(edit(config.read_text()))
    line = refused(processes, "train", "--resume", str(training), "--no-progress")
    assert line.startswith(f"Error: {config}: unusable training configuration (") and reason in line
    assert line.endswith("); restore it from a copy, or start a new training in another --out directory")


def test_evaluate_plays_a_training_without_pass_learners_with_hand_coded_pass(processes, tmp_path):
    trial = tmp_path / "training" / "trial_000"
    trial.mkdir(parents=True)
    save_policy(trial / "policy.npz", getopen_theta=np.zeros(getopen_theta_size()),
                config={"keepers": 3, "takers": 2, "pass": "handcoded", "getopen": "learned"})
    proc = processes.popen(keepaway_command("evaluate", "--policy", str(tmp_path / "training"), "--pass",
                                            "handcoded", "--episodes", "2", "--json",
                                            "--no-progress"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=PLAYING_S)
    assert proc.returncode == 0, err.decode()
    summary = json.loads(out)
    assert (summary["pass"], summary["getopen"], len(summary["episodes"])) == ("handcoded", "learned", 2)
    line = refused(processes, "evaluate", "--policy", str(tmp_path / "training"), "--pass", "learned",
                   timeout_s=PLAYING_S)
    assert line == f"Error: {trial / 'policy.npz'}: --pass learned needs Pass weights; the file has no Pass weights"


INTERRUPT_IN_GENERATED_CODE = '''
import click
_invoke = click.Command.invoke
def invoke(self, ctx):
    if self.name == "keys":  # as Ctrl-C lands in a dataclass's or numba's generated code at start-up
        exec("raise KeyboardInterrupt")
    return _invoke(self, ctx)
click.Command.invoke = invoke
'''


INTERRUPT_WHILE_COMMANDS_LOAD = '''
import sys
class InterruptAnImport:
    def find_spec(self, name, path=None, target=None):
        if name == "keepaway.viewer.cli":  # as Ctrl-C lands while keepaway.cli imports the commands' modules
            exec("raise KeyboardInterrupt")
        return None
sys.meta_path.insert(0, InterruptAnImport())
'''


@pytest.mark.parametrize("sitecustomize, line", [
    (INTERRUPT_IN_GENERATED_CODE, "keepaway keys: interrupted"),
    (INTERRUPT_WHILE_COMMANDS_LOAD, "keepaway: interrupted"),
], ids=["at-the-commands-start", "while-the-commands-load"])
def test_an_interrupt_before_a_command_catches_it_exits_130_in_one_line(processes, tmp_path, sitecustomize, line):
    """Ctrl-C before a command catches it itself: one line and exit 130, neither click's "Aborted!" and 1
    nor Python's traceback. At the command's start (its imports, its kernels' loads), raised inside code
    run from a string, as it is when it lands in a dataclass's, a namedtuple's or numba's generated code
    (it made ``python -m keepaway`` end with -SIGINT: keepaway/__main__.py); and earlier, in the command
    line's first half-second, while ``keepaway.cli`` imports every command's module."""
    (tmp_path / "sitecustomize.py").write_text(sitecustomize)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    proc = processes.popen(keepaway_command("keys", str(tmp_path / "keys")), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, env=env)
    _, err_bytes = proc.communicate(timeout=QUICK_S)
    err = err_bytes.decode()
    assert proc.returncode == 130, err
    assert err.strip() == line
    assert not (tmp_path / "keys").exists()


@pytest.mark.parametrize("args, option", [
    (["player", "--team", "keepers", "--connect-timeout", "nan"], "--connect-timeout"),
    (["player", "--team", "keepers", "--server-silence", "inf"], "--server-silence"),
    (["coach", "--server", "tcp://127.0.0.1:9", "--connect-timeout", "nan"], "--connect-timeout"),
    (["train", "--cem-extra-noise", "nan"], "--cem-extra-noise"),
    (["view", "{rcg}", "--field-size", "nan"], "--field-size"),
    (["render", "{rcg}", "--scale", "nan"], "--scale"),
    (["render", "{rcg}", "--fps", "nan"], "--fps"),
])
def test_a_number_that_is_not_finite_is_refused_naming_its_option(processes, tmp_path, args, option):
    rcg = tmp_path / "game.rcg"
    rcg.write_text("ULG5\n")
    line = refused(processes, *(arg.format(rcg=rcg) for arg in args))
    assert option in line and "is not a finite number" in line
