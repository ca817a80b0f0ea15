"""``keepaway experiment figure3`` / ``table2`` (trainer/experiments.py and the modules it builds on:
trainer/configurations.py, trainer/experiment_report.py, trainer/timing.py, trainer/worker_pool.py;
trainer/experiment_cli.py).

docs/players.md §8.3: the nine Pass x GetOpen configurations with learning curves (mean and standard
error over trials), the specialisation cross-tests with Welch's t-test. The experiment here is tiny
(48 training episodes, CEM generations of 4 candidates x 2 episodes, evaluations of 4 episodes, 2 trials),
run once per module and copied where a test changes it.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import llvmlite
import numba
import numpy as np
import pytest
from click.testing import CliRunner

import keepaway.trainer.experiment_report as experiment_report
import keepaway.trainer.experiments as experiments
import keepaway.trainer.timing as timing_module
import keepaway.trainer.worker_pool as worker_pool
from keepaway.cli import main
from keepaway.runner.backends import Placement
from keepaway.runner.batched_backend import BatchedBackend
from keepaway.runner.job import Behaviours
from keepaway.runner.report import dump_json
from keepaway.trainer.cem import CEMConfig
from keepaway.trainer.configurations import (
    POLICIES,
    ConfigurationRun,
    ExperimentConfig,
    configuration_dir,
    configuration_name,
)
from keepaway.trainer.curves import CurvePoint, read_curve_csv, welch_p_value, write_atomic, write_curve_csv
from keepaway.trainer.experiment_report import (
    Cell,
    CrossTable,
    plot_figure3,
    reference_levels,
    table_cells,
    write_final_evaluations,
)
from keepaway.trainer.experiments import with_counterpart
from keepaway.trainer.schedule import GETOPEN, LEARNED, PASS, Phase

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
# Evaluations at 0, 8, ..., 48 (7 points); Algorithm 3 scaled to 48: getopen 8, pass 8, getopen 24, pass 8.
TINY = ["--trials", "2", "--episodes", "48", "--eval-every", "8", "--eval-episodes", "4", "--population", "4",
        "--elite", "2", "--candidate-episodes", "2", "--seed", "3", "--threads", "1", "--no-progress"]
POINTS = [0, 8, 16, 24, 32, 40, 48]
NAMES = [f"P:{p}-GO:{g}" for p in ("R", "HC", "L") for g in ("R", "HC", "L")]


def strict_json(text: str):
    """``text`` parsed as RFC 8259 JSON: NaN and Infinity, which Python's parser accepts, are refused."""
    def refuse(constant: str):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def invoke(command: str, out: Path, *extra: str):
    return CliRunner().invoke(main, ["experiment", command, *TINY, *extra, "--out", str(out)])


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """An experiment directory after figure3 and then table2 ran in it."""
    out = tmp_path_factory.mktemp("experiment")
    for command in ("figure3", "table2"):
        result = invoke(command, out)
        assert result.exit_code == 0, result.output + repr(result.exception)
    return out


@pytest.fixture
def copy(finished, tmp_path) -> Path:
    shutil.copytree(finished, tmp_path / "experiment")
    return tmp_path / "experiment"


def forbid_playing(monkeypatch) -> None:
    """Make every episode a failure: what finished work must not need."""
    def refuse(*args, **kwargs):
        raise AssertionError("played episodes although the work was finished")

    monkeypatch.setattr(BatchedBackend, "play", refuse)
    monkeypatch.setattr(BatchedBackend, "play_all", refuse)


# -- statistics --------------------------------------------------------------------------------------
def test_figure3_tables_columns_and_ratios_by_hand():
    assert experiment_report.table_columns(list(range(0, 30001, 2500))) == [0, 2500, 5000, 10000, 20000, 30000]
    assert experiment_report.table_columns([0, 8, 16, 24, 32, 40, 48]) == [0, 8, 16, 32, 48]
    # 12.1 / 11.5 = 1.052; relative errors 0.3606 / sqrt(3) / 12.1 and 0.1 / sqrt(3) / 11.5: 1.052 x 0.0179
    assert experiment_report.ratio_text([12.0, 12.5, 11.8], [11.5, 11.6, 11.4]).startswith("1.05 +- 0.02 (p = ")
    assert experiment_report.ratio_text([3.0], [4.0]) == "0.75"  # one trial: no standard error, no test


def test_welch_p_value_by_hand():
    # a = 1, 2, 3 and b = 4, 5, 6: means 2 and 5, sample variances 1, squared standard errors 1/3 each;
    # t^2 = 9 / (2/3) = 27/2; df = (2/3)^2 / (2 (1/3)^2 / 2) = 4. Student's t with 4 degrees of freedom:
    # P(|T| > t) = 1 - (3/4) (t / s) (1 - t^2 / (12 s^2)), s^2 = 1 + t^2 / 4 = 35/8
    # = 1 - (3/4) sqrt(108/35) (26/35) = 0.021312.
    assert welch_p_value([1, 2, 3], [4, 5, 6]) == pytest.approx(1 - 0.75 * math.sqrt(108 / 35) * 26 / 35, rel=1e-12)
    # a = 0, 2 and b = 3, 5: t^2 = 9 / 2, df = 2; P(|T| > t) = 1 - t / sqrt(2 + t^2) = 1 - 3 / sqrt(13).
    assert welch_p_value([0, 2], [3, 5]) == pytest.approx(1 - 3 / math.sqrt(13), rel=1e-12)
    assert welch_p_value([0, 2], [3, 5]) == welch_p_value([3, 5], [0, 2])  # two-sided
    # one-sided: half the two-sided p in the direction of the difference
    assert welch_p_value([4, 5, 6], [1, 2, 3], alternative="greater") == pytest.approx(
        welch_p_value([1, 2, 3], [4, 5, 6]) / 2, rel=1e-12)


def test_welch_p_value_is_undefined_for_single_values_and_no_spread():
    assert welch_p_value([1.0], [2.0, 3.0]) is None
    assert welch_p_value([1.0, 1.0], [2.0, 2.0]) is None


def test_entries_that_differ_from_their_columns_best_are_marked():
    # Column 0: row 0 (mean 10) is best; row 1 (mean 5, tiny spread) differs, row 2 (mean 9.9) does not.
    # Column 1: row 2 is best (mean 7); nothing else is far enough from it to be told apart.
    values = [[[10.0, 10.1, 9.9], [5.0, 6.0, 7.0]],
              [[5.0, 5.1, 4.9], [6.5, 5.5, 7.5]],
              [[9.0, 10.7, 10.0], [7.0, 6.0, 8.0]]]
    cells = table_cells(values)
    assert [[c.best for c in row] for row in cells] == [[True, False], [False, False], [False, True]]
    assert [[c.significant for c in row] for row in cells] == [[False, False], [True, False], [False, False]]
    assert cells[0][0].p_value is None
    # Row 1, column 0: mean 5, s.e. sqrt(0.01 / 3) = 0.0577.
    assert cells[1][0].text() == "5.00 +- 0.06*"
    assert cells[0][0].text() == "**10.00 +- 0.06**"


def test_a_cross_table_prints_three_by_three_with_marks():
    far, near = (10.0, 10.2, 9.8), (1.0, 1.1, 0.9)
    # Diagonal far above the rest: every column's best is the policy trained with that counterpart.
    values = [[list(far if r == c else near) for c in range(3)] for r in range(3)]
    table = CrossTable(PASS, table_cells(values))
    lines = table.markdown().splitlines()
    rows = [line for line in lines if line.startswith("| GO:")]
    assert len(rows) == 3 and all(row.count("|") == 5 for row in rows)
    assert all(row.count("*") == 4 + 2 for row in rows)  # its bold best (**..**) and two marked entries
    assert table.best_on_diagonal() == [True, True, True]
    data = table.to_dict()
    assert data["rows"] == data["columns"] == ["GO:R", "GO:HC", "GO:L"]
    assert [[c["significant"] for c in row] for row in data["cells"]] == [[r != c for c in range(3)] for r in range(3)]


# -- configurations ----------------------------------------------------------------------------------
def test_algorithm_3_is_scaled_to_the_experiments_length():
    exp = ExperimentConfig(episodes=48, eval_every=8, cem=CEMConfig(population=4, elite=2, episodes_per_candidate=2))
    # 5,000 / 5,000 / 15,000 / 5,000 of 30,000 -> 8 / 8 / 24 / 8 of 48.
    assert exp.schedule(LEARNED, LEARNED) == (Phase(GETOPEN, 8), Phase(PASS, 8), Phase(GETOPEN, 24), Phase(PASS, 8))
    assert exp.schedule(LEARNED, "handcoded") == (Phase(PASS, 48),)
    assert exp.points() == POINTS
    with pytest.raises(ValueError, match="multiple of 6"):
        ExperimentConfig(episodes=50).schedule(LEARNED, LEARNED)


def test_a_learned_policy_meets_a_learned_counterpart_from_the_partner_run():
    theta, other = np.zeros(91), np.ones(91)
    pass_arrays = [{"pass_weights": np.ones(3)}]
    trained = Behaviours(LEARNED, "handcoded", None, pass_arrays)
    partner = Behaviours(LEARNED, LEARNED, other, [{"pass_weights": np.zeros(3)}])
    tested = with_counterpart(trained, PASS, LEARNED, partner)
    assert tested.getopen_policy == LEARNED and tested.getopen_theta is other and tested.pass_arrays is pass_arrays
    getopen_trained = Behaviours("random", LEARNED, theta)
    assert with_counterpart(getopen_trained, GETOPEN, "handcoded", partner) == Behaviours("handcoded", LEARNED, theta)
    assert with_counterpart(getopen_trained, GETOPEN, LEARNED, partner).pass_arrays is partner.pass_arrays


# -- the commands ------------------------------------------------------------------------------------
@pytest.mark.slow
def test_figure3_writes_a_png_and_final_evaluations_of_nine_configurations(finished):
    assert (finished / "figure3.png").read_bytes().startswith(PNG_MAGIC)
    with open(finished / "figure3.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["name"] for r in rows] == NAMES
    assert all(r["trials"] == "2" and r["episodes"] == "48" and r["stderr_over"] == "trials" for r in rows)
    data = strict_json((finished / "figure3.json").read_text())
    for row, configuration in zip(rows, data["configurations"]):
        assert [p["episodes"] for p in configuration["curve"]] == POINTS
        assert float(row["final_mean_hold_time_s"]) == configuration["curve"][-1]["mean_hold_time_s"] > 0.0
        assert math.isfinite(float(row["final_stderr_hold_time_s"]))
    # Hand-coded keepers hold the ball far longer than random ones (docs/players.md §8.3).
    finals = {r["name"]: float(r["final_mean_hold_time_s"]) for r in rows}
    assert finals["P:HC-GO:HC"] > 2 * finals["P:R-GO:R"]
    # the same as a table: the pairs first, five columns of the curve, the final beside the hand-coded pair's
    table = (finished / "figure3.md").read_text().splitlines()
    assert table[0].startswith("| configuration | trials | 0 | 8 | 16 | 32 | 48 episodes | / P:HC-GO:HC at 48")
    assert len(table) == 2 + 9 and table[2].startswith("| P:HC-GO:HC (hand-coded pair) | 2 | ")
    assert table[2].endswith(" | 1 |") and table[3].startswith("| P:R-GO:R (random pair) | 2 | ")
    finals = {c["name"]: c["curve"][-1]["mean_hold_time_s"] for c in data["configurations"]}
    ratio = table[3].split(" | ")[-1]
    assert ratio.startswith(f"{finals['P:R-GO:R'] / finals['P:HC-GO:HC']:.2f} +- ") and "(p = " in ratio
    # what each configuration cost, in the one sitting that played it
    timings = [c["timing"] for c in data["configurations"]]
    assert all(t["sittings"] == 1 and t["wall_s"] > 0.0 and t["cpu_s"] > 0.0 for t in timings)
    assert data["timing"]["wall_s"] == pytest.approx(sum(t["wall_s"] for t in timings))


@pytest.mark.slow
def test_a_configuration_without_learning_is_measured_at_every_evaluation_point(finished):
    for trial in range(2):
        curve = read_curve_csv(configuration_dir(finished, "handcoded", "random") / f"trial_{trial:03d}" / "curve.csv")
        assert [p.episodes for p in curve] == POINTS
        assert len({p.mean_hold_time_s for p in curve}) > 1  # measured at each point, not copied


@pytest.mark.slow
def test_table2_writes_two_three_by_three_tables(finished):
    data = strict_json((finished / "table2.json").read_text())
    tables = {t["study"]: t for t in data["tables"]}
    assert set(tables) == {PASS, GETOPEN}
    for table in tables.values():
        assert len(table["cells"]) == 3 and all(len(row) == 3 for row in table["cells"])
        assert all(len(cell["values"]) == 2 for row in table["cells"] for cell in row)
        for column in range(3):
            assert sum(row[column]["best"] for row in table["cells"]) == 1
    # Pass learned with GO:L tested with GO:L and GetOpen learned with P:L tested with P:L are the same
    # pair of policies (P:L-GO:L's) on the same seeds.
    assert tables[PASS]["cells"][2][2]["values"] == tables[GETOPEN]["cells"][2][2]["values"]
    markdown = (finished / "table2.md").read_text()
    assert markdown.count("| GO:") == 3 and markdown.count("| P:") == 3


@pytest.mark.slow
def test_running_again_skips_finished_work(copy, monkeypatch):
    checkpoint = configuration_dir(copy, LEARNED, LEARNED) / "trial_001" / "checkpoint.npz"
    before = checkpoint.stat().st_mtime_ns
    (configuration_dir(copy, LEARNED, LEARNED) / "summary.json").unlink()  # resumed through the train API
    for stored in (copy / "table2_tests").glob("trial_*.json"):  # tests stored before the hive mind existed
        record = json.loads(stored.read_text())
        del record["experiment"]["pass_hive_mind"]
        stored.write_text(json.dumps(record))
    forbid_playing(monkeypatch)
    skipped = []
    for command in ("figure3", "table2"):
        result = invoke(command, copy)
        assert result.exit_code == 0, result.output + repr(result.exception)
        skipped.append(result.output.count("finished before, skipped"))
    assert skipped == [8, 5]  # figure3 resumed P:L-GO:L (no summary) without playing; table2 needs 5
    assert checkpoint.stat().st_mtime_ns == before
    assert (configuration_dir(copy, LEARNED, LEARNED) / "summary.json").is_file()
    # the resumed configuration had a second sitting; the skipped ones and the cached tests none
    figure = json.loads((copy / "figure3.json").read_text())
    sittings = {c["name"]: c["timing"]["sittings"] for c in figure["configurations"]}
    assert sittings == {name: 2 if name == "P:L-GO:L" else 1 for name in NAMES}
    assert json.loads((copy / "table2.json").read_text())["tests_timing"]["sittings"] == 1


def test_a_sitting_interrupted_right_after_its_first_record_still_ends_it(tmp_path, monkeypatch):
    # Ctrl-C (or a worker's SIGINT) landing just after the "running" record is written, before the work
    # starts: the record must still end (an interrupted worker of `experiment --workers` hit this window).
    written = []

    def write_then_interrupt(path, data):
        write_atomic(path, data)
        written.append(path)
        if len(written) == 1:
            raise KeyboardInterrupt

    monkeypatch.setattr(timing_module, "write_atomic", write_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        with timing_module.timed_sitting(tmp_path):
            pytest.fail("the work must not start")
    (sitting,) = json.loads((tmp_path / "timing.json").read_text())["sittings"]
    assert "running" not in sitting and len(written) == 2


class _HalfStarted:
    """A thread whose start() was interrupted after the new thread took its ident and before it set its
    start flag: the real join() raises RuntimeError("cannot join thread before it is started") then."""

    def __init__(self, **_: object) -> None:
        self.ident = 1

    def start(self) -> None:
        raise KeyboardInterrupt

    def join(self) -> None:
        raise RuntimeError("cannot join thread before it is started")


def test_a_sitting_interrupted_while_its_refresher_starts_still_ends_it(tmp_path, monkeypatch):
    # the window an interrupted worker of `experiment --workers` hit on a busy CI machine: its record
    # stayed "running" because the end waited for a thread that could not be joined
    monkeypatch.setattr(timing_module.threading, "Thread", _HalfStarted)
    with pytest.raises(KeyboardInterrupt):
        with timing_module.timed_sitting(tmp_path):
            pytest.fail("the work must not start")
    monkeypatch.undo()
    (sitting,) = json.loads((tmp_path / "timing.json").read_text())["sittings"]
    assert "running" not in sitting


def test_a_sitting_is_timed_even_when_it_is_interrupted(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        with timing_module.timed_sitting(tmp_path):
            raise KeyboardInterrupt
    with timing_module.timed_sitting(tmp_path):
        start = time.process_time()
        while time.process_time() - start < 0.05:  # some CPU
            pass
    timing = timing_module.Timing.read(tmp_path)
    assert timing.sittings == 2 and timing.wall_s >= 0.05 and timing.cpu_s >= 0.04
    assert timing_module.Timing.read(tmp_path / "none") == timing_module.Timing()
    assert not any("running" in s for s in json.loads((tmp_path / "timing.json").read_text())["sittings"])


def test_a_sitting_killed_by_sigkill_keeps_its_last_refresh(tmp_path):
    # the machine's end or a SIGKILL runs no finally: the record rewritten while the sitting runs remains
    script = ("import sys, time; from pathlib import Path; from keepaway.trainer.timing import timed_sitting\n"
              "with timed_sitting(Path(sys.argv[1]), refresh_s=0.05):\n"
              "    while True: time.process_time()\n")
    child = subprocess.Popen([sys.executable, "-c", script, str(tmp_path)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while timing_module.Timing.read(tmp_path).cpu_s < 0.2 and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        child.kill()
        child.wait()
    (sitting,) = json.loads((tmp_path / "timing.json").read_text())["sittings"]
    assert sitting["running"] is True and sitting["cpu_s"] >= 0.2 and sitting["wall_s"] > 0


@pytest.mark.slow
def test_an_unfinished_evaluation_continues_where_it_stopped(copy, monkeypatch):
    where = configuration_dir(copy, "handcoded", "handcoded")
    path = where / "trial_001" / "curve.csv"
    complete = read_curve_csv(path)
    write_curve_csv(path, complete[:-2])
    played = []
    original = BatchedBackend.play_all

    def counting(self, jobs, *args, **kwargs):
        played.append(len(jobs))
        return original(self, jobs, *args, **kwargs)

    monkeypatch.setattr(BatchedBackend, "play_all", counting)
    run = experiments.run_configuration(ExperimentConfig(trials=2, episodes=48, eval_every=8, eval_episodes=4,
                                                         seed=3), "handcoded", "handcoded", copy,
                                        Placement(threads=1), progress=False)
    assert played == [1, 1] and not run.skipped  # the two missing points of the one unfinished trial
    assert read_curve_csv(path) == complete  # the same seeds give the same evaluations


@pytest.mark.slow
@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_directory_of_other_settings_is_refused(copy, workers):
    result = CliRunner().invoke(main, ["experiment", "figure3", *TINY, "--eval-episodes", "6", "--workers", workers,
                                       "--out", str(copy)])
    assert result.exit_code == 2 and "holds a different" in result.output


@pytest.mark.slow
def test_configurations_trained_in_worker_processes_give_the_same_results(finished, tmp_path):
    result = invoke("figure3", tmp_path, "--workers", "2")
    assert result.exit_code == 0, result.output + repr(result.exception)
    ours, theirs = (json.loads((where / "figure3.json").read_text())["configurations"]
                    for where in (tmp_path, finished))
    assert [(c["name"], c["curve"]) for c in ours] == [(c["name"], c["curve"]) for c in theirs]
    for name in NAMES:  # each trial's curve too, and its timing was recorded in the worker
        where = tmp_path / name.replace(":", "_")
        assert [read_curve_csv(where / f"trial_{t:03d}" / "curve.csv") for t in range(2)] == \
            [read_curve_csv(finished / name.replace(":", "_") / f"trial_{t:03d}" / "curve.csv") for t in range(2)]
        assert timing_module.Timing.read(where).sittings == 1
    # each configuration reported once, as it ended: the longest started first
    reported = [line.split(": ")[0] for line in result.output.splitlines() if line.startswith("P:")]
    assert sorted(reported) == sorted(NAMES)
    assert reported.index("P:L-GO:HC") < reported.index("P:R-GO:R")


def test_configurations_trained_together_give_the_same_results_and_table2_too(finished, tmp_path):
    # The five learning configurations side by side in one process (trainer.experiments.train_together:
    # their jobs in shared batches of arenas of different policies), then the four fixed ones; then
    # Table 2, whose 18 cross-tests per trial share one batch.
    result = invoke("figure3", tmp_path, "--together", "--threads", "2")
    assert result.exit_code == 0, result.output + repr(result.exception)
    ours, theirs = (json.loads((where / "figure3.json").read_text())["configurations"]
                    for where in (tmp_path, finished))
    assert [(c["name"], c["curve"]) for c in ours] == [(c["name"], c["curve"]) for c in theirs]
    for name in NAMES:
        where = tmp_path / name.replace(":", "_")
        assert [read_curve_csv(where / f"trial_{t:03d}" / "curve.csv") for t in range(2)] == \
            [read_curve_csv(finished / name.replace(":", "_") / f"trial_{t:03d}" / "curve.csv") for t in range(2)]
    assert timing_module.Timing.read(tmp_path / "together").sittings == 1
    reported = [line.split(": ")[0] for line in result.output.splitlines() if line.startswith("P:")]
    assert sorted(reported) == sorted(NAMES)
    assert "P:L-GO:HC: done; final evaluation" in result.output and "timed with the others" in result.output
    result = invoke("table2", tmp_path, "--together")
    assert result.exit_code == 0, result.output + repr(result.exception)
    assert "finished before, skipped" in result.output
    assert (tmp_path / "table2.md").read_text() == (finished / "table2.md").read_text()
    both = invoke("figure3", tmp_path / "both", "--together", "--workers", "2")
    assert both.exit_code == 2 and "not both" in both.output


def children_of(pid: int) -> set[int]:
    """The direct children of ``pid`` (from /proc)."""
    found = set()
    for entry in Path("/proc").iterdir():
        try:
            if entry.name.isdigit() and int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1]) == pid:
                found.add(int(entry.name))
        except (OSError, ValueError, IndexError):
            continue
    return found


@pytest.mark.parametrize("name, filename", [
    # llvmlite's object-cache hook, which numba's cached kernels load through: a ctypes callback that
    # prints an exception raised in it and carries on
    ("_raw_object_cache_getbuffer", os.path.join(os.path.dirname(llvmlite.__file__), "binding", "executionengine.py")),
    # numba loading a kernel (interrupted there, numba's state stays half made: a CI worker died of SIGSEGV)
    ("load_overload", os.path.join(os.path.dirname(numba.__file__), "core", "caching.py")),
    # a finalizer anywhere (a CI run's worker lost its interrupt in llvmlite's ObjectRef.__del__)
    ("__del__", "/elsewhere/common.py"),
])
def test_a_worker_interrupted_where_an_exception_must_not_be_raised_is_interrupted_again_after_it(name, filename):
    namespace: dict = {}
    exec(compile(f"def {name}(handler):\n    import sys\n    handler(2, sys._getframe())\n", filename, "exec"),
         namespace)
    received = []
    previous, previous_term = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum)), \
        signal.getsignal(signal.SIGTERM)
    try:
        namespace[name](worker_pool._interrupt_once)  # not raised in there
        deadline = time.monotonic() + 5.0
        while not received and time.monotonic() < deadline:
            time.sleep(0.01)
        assert received == [signal.SIGINT]  # delivered again, to be raised where it is not dropped
        with pytest.raises(KeyboardInterrupt):
            worker_pool._interrupt_once(signal.SIGINT, sys._getframe())
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN  # later ones are ignored
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.signal(signal.SIGTERM, previous_term)


def _worker_ending(send, ending: str) -> None:
    if ending == "crash":
        os._exit(3)
    if ending == "interrupted before its handler":
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    send.send(RuntimeError("disk full") if ending == "error" else KeyboardInterrupt())


@pytest.mark.parametrize("ending, warning", [
    ("interrupted", None),
    ("interrupted before its handler", None),
    ("error", "the interrupted worker of P:L-GO:HC ended with exit code 0 and RuntimeError: disk full"),
    ("crash", "the interrupted worker of P:L-GO:HC ended with exit code 3 and no result")])
def test_an_interrupted_worker_that_ends_otherwise_is_named_with_its_exit_code(ending, warning, caplog):
    context = multiprocessing.get_context("fork")  # the target is a test's function: spawn could not import it
    receive, send = context.Pipe(duplex=False)
    process = context.Process(target=_worker_ending, args=(send, ending))
    process.start()
    send.close()
    with caplog.at_level(logging.WARNING, "keepaway.experiment"):
        worker_pool._join_interrupted(receive, process, "P:L-GO:HC")
    assert not process.is_alive()
    assert [r.getMessage().removeprefix("keepaway experiment: ") for r in caplog.records] == (
        [warning] if warning else [])


def _until_two_workers_train(proc: subprocess.Popen, out: Path) -> tuple[set[int], set[int]]:
    """(children, workers) of a running ``experiment figure3 --workers 2`` once both workers run and the
    longest configuration's is training."""
    children: set[int] = set()
    workers: set[int] = set()
    deadline = time.monotonic() + 120
    started = out / "P_L-GO_HC" / "timing.json"
    while time.monotonic() < deadline and not (len(workers) == 2 and started.is_file()):
        children = children_of(proc.pid)  # the two workers and multiprocessing's resource tracker
        workers = {pid for pid in children if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()}
        time.sleep(0.1)
    assert len(workers) == 2 and started.is_file(), "the workers did not start"
    return children, workers


def _figure3_in_two_workers(out: Path, pipe: int) -> subprocess.Popen:
    """``experiment figure3 --workers 2``, far longer than the tests wait for, its output to ``pipe``; started
    with SIGINT's default disposition, as from a terminal (a test run started in the background by a
    non-interactive shell ignores SIGINT, and its children would inherit that)."""
    longer = [*TINY, "--episodes", "60000", "--eval-every", "10000"]
    return subprocess.Popen([sys.executable, "-m", "keepaway", "experiment", "figure3", *longer, "--workers", "2",
                             "--out", str(out)], stdout=pipe, stderr=pipe,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _alive(pid: int) -> bool:
    try:
        return "zombie" not in Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds the worker processes through /proc")
def test_an_interrupted_run_in_worker_processes_stops_them_and_keeps_their_timing(tmp_path):
    proc = _figure3_in_two_workers(tmp_path, subprocess.PIPE)
    children: set[int] = set()
    workers: set[int] = set()
    started = tmp_path / "P_L-GO_HC" / "timing.json"
    try:
        children, workers = _until_two_workers_train(proc, tmp_path)
        proc.send_signal(signal.SIGINT)  # to the parent alone: it interrupts its workers
        try:
            out, err = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:  # show what it wrote
            proc.kill()
            _, err = proc.communicate()
            pytest.fail("the run did not stop within 120 s of its SIGINT; its stderr ends:\n" + err.decode()[-6000:])
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, err.decode()
    assert err.decode().strip().splitlines()[-1].startswith("keepaway experiment: interrupted; run the same command")
    assert not [pid for pid in workers if _alive(pid)], "a worker outlived the run that joins it"
    # multiprocessing's resource tracker exits by itself once the run's end closes its pipe: on a busy
    # machine that may take a moment after the run has returned
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(_alive(pid) for pid in children):
        time.sleep(0.1)
    assert not [pid for pid in children if _alive(pid)], "a child process outlived the run"
    # the interrupted sitting ended in its worker's finally, not at a refresh
    (sitting,) = json.loads(started.read_text())["sittings"]
    assert "running" not in sitting and sitting["wall_s"] > 0, err.decode()


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds the worker processes through /proc")
def test_the_workers_of_a_killed_run_stop_too(tmp_path):
    proc = _figure3_in_two_workers(tmp_path, subprocess.DEVNULL)
    workers: set[int] = set()
    try:
        _, workers = _until_two_workers_train(proc, tmp_path)
        proc.kill()  # no chance to interrupt them: Linux's parent-death signal must
        proc.wait()
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and any(_alive(pid) for pid in workers):
            time.sleep(0.1)
        assert not [pid for pid in workers if _alive(pid)], "a worker went on after its run was killed"
    finally:
        if proc.poll() is None:
            proc.kill()
        for pid in workers:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass


def test_worker_processes_do_not_attach_to_running_arenas(tmp_path):
    result = invoke("figure3", tmp_path, "--workers", "2", "--mode", "distributed", "--arena", "tcp://127.0.0.1:1")
    assert result.exit_code == 2 and "not with --arena or --backend ray" in result.output


def test_settings_that_cannot_be_trained_are_usage_errors(tmp_path):
    # Generations of 2 x 1 episodes fit 50 episodes of GO:L, but Algorithm 3's proportions do not.
    result = CliRunner().invoke(main, ["experiment", "table2", *TINY, "--episodes", "50", "--population", "2",
                                       "--candidate-episodes", "1", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "multiple of 6" in result.output
    assert not any(tmp_path.iterdir())


def test_every_cell_of_a_table_reports_its_trials():
    cell = Cell((4.0, 6.0), best=False, p_value=0.2)
    # mean 5, sample standard deviation sqrt(2), s.e. sqrt(2) / sqrt(2) = 1.
    assert (cell.mean, cell.stderr, cell.significant) == (5.0, 1.0, False)


def test_a_table_of_one_trial_has_no_standard_errors_or_tests_and_says_so():
    values = [[[10.0], [5.0]], [[5.0], [6.5]], [[9.0], [7.0]]]
    cells = table_cells(values)
    assert all(c.stderr is None and c.p_value is None and not c.significant for row in cells for c in row)
    assert cells[0][0].text() == "**10.00 +- n/a**" and cells[1][0].text() == "5.00 +- n/a"
    table = CrossTable(PASS, table_cells([[[float(r == c)] for c in range(3)] for r in range(3)]))
    assert "over 1 trial (n/a: one trial has none, and no test)" in table.markdown()
    data = strict_json(dump_json(table.to_dict()))
    assert all(c["stderr_hold_time_s"] is None and c["p_value"] is None for row in data["cells"] for c in row)


def one_trial_runs(eval_episodes: int = 4) -> list[ConfigurationRun]:
    """Figure 3's nine configurations with one trial each, flat curves at 2 s (R), 8 s (HC) and 5 s (L),
    the last point of P:R-GO:R without a standard error (an evaluation of one episode)."""
    level = {"random": 2.0, "handcoded": 8.0, LEARNED: 5.0}
    runs = []
    for p in POLICIES:
        for g in POLICIES:
            mean = (level[p] + level[g]) / 2
            curve = [CurvePoint(e, mean + e / 100, 0.5) for e in POINTS]
            if (p, g) == ("random", "random"):
                curve[-1] = CurvePoint(POINTS[-1], mean, None)
            runs.append(ConfigurationRun(configuration_name(p, g), p, g, [curve], False, eval_episodes))
    return runs


def test_figure3_of_one_trial_writes_strict_json_and_names_the_standard_errors(tmp_path):
    runs = one_trial_runs()
    write_final_evaluations(tmp_path, ExperimentConfig(trials=1), runs)
    data = strict_json((tmp_path / "figure3.json").read_text())
    rows = {c["name"]: c for c in data["configurations"]}
    assert all(c["stderr_over"] == "episodes" for c in rows.values())
    assert rows["P:HC-GO:HC"]["final_stderr_hold_time_s"] == 0.5  # the trial's last evaluation's, over episodes
    assert rows["P:R-GO:R"]["final_stderr_hold_time_s"] is None
    with open(tmp_path / "figure3.csv", newline="") as f:
        csv_rows = {r["name"]: r for r in csv.DictReader(f)}
    assert csv_rows["P:R-GO:R"]["final_stderr_hold_time_s"] == "" and csv_rows["P:R-GO:R"]["stderr_over"] == "episodes"
    assert runs[0].stderr_basis() == "s.e. over 4 episodes of 1 trial"


def test_figure3_draws_the_measured_hand_coded_and_random_levels_as_labelled_lines(tmp_path):
    runs = one_trial_runs()
    # P:HC-GO:HC's curve is 8 + e / 100 at e = 0, 8, ..., 48: mean 8.24; P:R-GO:R's 2 + e / 100 but 2 at 48.
    levels = reference_levels(runs)
    assert list(levels) == ["P:HC-GO:HC (hand-coded)", "P:R-GO:R (random)"]
    assert levels["P:HC-GO:HC (hand-coded)"] == pytest.approx(8.24)
    assert levels["P:R-GO:R (random)"] == pytest.approx(2.0 + sum(POINTS[:-1]) / 100 / len(POINTS))
    assert reference_levels([r for r in runs if r.pass_policy == LEARNED]) == {}  # not measured: not drawn
    plot_figure3(tmp_path / "figure3.png", runs)
    assert (tmp_path / "figure3.png").read_bytes().startswith(PNG_MAGIC)


def test_configurations_are_seeded_independently():
    exp = ExperimentConfig(seed=3)
    seeds = {exp.train_config(p, g).seed for p, g in (("random", LEARNED), (LEARNED, LEARNED), (LEARNED, "random"))}
    seeds.add(exp.fixed_record("random", "random")["seed"])
    assert len(seeds) == 4
    assert exp.train_config(LEARNED, LEARNED).seed == ExperimentConfig(seed=3).train_config(LEARNED, LEARNED).seed


def test_only_runs_the_named_configurations_and_draws_nothing(tmp_path):
    result = invoke("figure3", tmp_path, "--only", "P:HC-GO:HC", "--only", "P_R-GO_R")
    assert result.exit_code == 0, result.output + repr(result.exception)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["P_HC-GO_HC", "P_R-GO_R"]
    assert "ran 2 of 9 configurations" in result.output
    assert [line.split(":")[0:2] for line in result.output.splitlines()[:2]] == [["P", "R-GO"], ["P", "HC-GO"]]


def test_an_unknown_configuration_name_is_a_one_line_usage_error(tmp_path):
    result = invoke("figure3", tmp_path, "--only", "P:HC-GO:X")
    assert result.exit_code == 2
    assert "unknown configuration 'P:HC-GO:X'; choose from P:R-GO:R" in result.output
    assert not any(tmp_path.iterdir())
