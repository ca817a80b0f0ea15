"""Episode logs: the rcssserver .kwy file and the JSON-lines log (spec `server-physics.md` 5 "kwy log")."""

from __future__ import annotations

import json
import re
import time

import pytest

from keepaway.protocol.params import CLASSIC
from keepaway.server.episode_log import EpisodeRecord, JsonlLog, KwyLog, cpp_number, free_name, read_jsonl

# The spec's example, byte for byte (tab-separated episode lines).
SPEC_EXAMPLE = (
    "# Keepers: 3\n"
    "# Takers:  2\n"
    "# Region:  20 x 20\n"
    "#\n"
    "# Description of Fields:\n"
    "# 1) Episode number\n"
    "# 2) Start time in simulator steps (100ms)\n"
    "# 3) End time in simulator steps (100ms)\n"
    "# 4) Duration in simulator steps (100ms)\n"
    "# 5) (o)ut of bounds / (t)aken away\n"
    "#\n"
    "1\t0\t2\t2\to\n"
    "2\t2\t28\t26\to\n"
    "3\t28\t93\t65\tt\n"
)
EPISODES = [
    EpisodeRecord(episode=1, start_cycle=0, end_cycle=2, end="out"),
    EpisodeRecord(episode=2, start_cycle=2, end_cycle=28, end="out"),
    EpisodeRecord(episode=3, start_cycle=28, end_cycle=93, end="taken"),
]


def test_kwy_matches_the_spec_example_byte_for_byte(tmp_path):
    log = KwyLog(tmp_path, 3, 2, 20.0, 20.0, fixed_name="rcssserver")
    for record in EPISODES:
        log.write(record)
    log.close()
    assert log.path == tmp_path / "rcssserver.kwy"
    assert (tmp_path / "rcssserver.kwy").read_bytes() == SPEC_EXAMPLE.encode("ascii")


@pytest.mark.parametrize("value, text", [(20.0, "20"), (17.5, "17.5"), (1 / 3, "0.333333"),
                                         (123.456789, "123.457"), (1234567.0, "1.23457e+06")])
def test_region_numbers_print_as_cpp_streams_do(value, text):
    assert cpp_number(value) == text


def test_kwy_region_line_for_a_non_integer_region(tmp_path):
    with KwyLog(tmp_path, 4, 3, 25.0, 17.5, fixed_name="k") as log:
        pass
    lines = log.path.read_text().splitlines()
    assert lines[:3] == ["# Keepers: 4", "# Takers:  3", "# Region:  25 x 17.5"]


def test_kwy_lines_are_on_disk_before_close(tmp_path):
    log = KwyLog(tmp_path, 3, 2, 20.0, 20.0, fixed_name="live")
    log.write(EPISODES[0])
    assert (tmp_path / "live.kwy").read_text().endswith("1\t0\t2\t2\to\n")
    log.close()


def test_unfixed_kwy_is_incomplete_until_closed_then_renamed(tmp_path):
    log = KwyLog(tmp_path, 3, 2, 20.0, 20.0)
    assert log.path == tmp_path / "incomplete.kwy"
    log.write(EPISODES[2])
    assert (tmp_path / "incomplete.kwy").exists()
    log.close(left_score=0, right_score=0)
    log.close()  # idempotent
    assert not (tmp_path / "incomplete.kwy").exists()
    assert re.fullmatch(r"\d{14}-keepers_0-vs-takers_0\.kwy", log.path.name), log.path.name
    assert log.path.parent == tmp_path
    assert log.path.read_text().endswith("3\t28\t93\t65\tt\n")
    with pytest.raises(ValueError):
        log.write(EPISODES[0])


def test_unfixed_kwy_names_an_absent_team_null(tmp_path):
    log = KwyLog(tmp_path, 3, 0, 20.0, 20.0, left_team="K3", right_team=None)
    log.close(left_score=2)
    assert re.fullmatch(r"\d{14}-K3_2-vs-null\.kwy", log.path.name), log.path.name


def test_fixed_kwy_keeps_its_name_at_close(tmp_path):
    log = KwyLog(tmp_path / "logs", 3, 2, 20.0, 20.0, fixed_name="run1")
    log.close(left_score=1)
    assert log.path == tmp_path / "logs" / "run1.kwy"
    assert log.path.exists()


def test_episode_record_duration_and_hold_time():
    # 93 - 28 = 65 cycles; at 100 ms per cycle 6.5 s, at 50 ms 3.25 s.
    assert EPISODES[2].duration == 65
    assert EPISODES[2].hold_time_s == pytest.approx(6.5)
    assert EpisodeRecord(3, 28, 93, "taken", simulator_step_ms=50.0).hold_time_s == pytest.approx(3.25)
    with pytest.raises(ValueError):
        EpisodeRecord(1, 0, 5, "o")
    with pytest.raises(ValueError):
        EpisodeRecord(1, 5, 4, "out")


def _jsonl(tmp_path):
    path = tmp_path / "episodes.jsonl"
    log = JsonlLog(path, seed=42, config={"keepers": 3, "takers": 2}, params=CLASSIC.to_dict())
    for record in EPISODES:
        log.write(record)
    return path, log


def test_jsonl_header_and_episode_lines(tmp_path):
    path, log = _jsonl(tmp_path)
    log.close()
    log.close()
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert lines[0] == {"type": "header", "format": "keepaway-episodes", "version": 1, "seed": 42,
                        "config": {"keepers": 3, "takers": 2}, "params": CLASSIC.to_dict()}
    assert lines[3] == {"type": "episode", "episode": 3, "start_cycle": 28, "end_cycle": 93,
                        "duration": 65, "hold_time_s": 6.5, "end": "taken", "missed": {}}
    header, episodes = read_jsonl(path)
    assert header["seed"] == 42
    assert episodes == EPISODES


def test_jsonl_lines_are_readable_before_close(tmp_path):
    path, log = _jsonl(tmp_path)
    assert read_jsonl(path)[1] == EPISODES
    log.close()


def test_read_jsonl_skips_a_truncated_last_line(tmp_path):
    path, log = _jsonl(tmp_path)
    log.close()
    with open(path, "a") as f:
        f.write('{"type": "episode", "episode": 4, "start_cy')
    header, episodes = read_jsonl(path)
    assert episodes == EPISODES


def test_read_jsonl_rejects_a_malformed_middle_line_and_a_missing_header(tmp_path):
    path, log = _jsonl(tmp_path)
    log.close()
    lines = path.read_text().splitlines(keepends=True)
    path.write_text(lines[0] + '{"type": "epis\n' + "".join(lines[1:]))
    with pytest.raises(ValueError, match=":2:"):
        read_jsonl(path)
    path.write_text("".join(lines[1:]))
    with pytest.raises(ValueError, match="no header"):
        read_jsonl(path)


def test_read_jsonl_uses_the_logged_step_length(tmp_path):
    path = tmp_path / "fast.jsonl"
    with JsonlLog(path, seed=1, config={}, params=CLASSIC.replace(simulator_step_ms=50.0).to_dict()) as log:
        log.write(EPISODES[2])
    _, episodes = read_jsonl(path)
    assert episodes[0].hold_time_s == pytest.approx(3.25)  # 65 cycles x 50 ms


def test_jsonl_marks_the_players_an_episode_was_played_without(tmp_path):
    short = EpisodeRecord(4, 93, 150, "out", missed=(("keeper 2", 25), ("taker 1", 3)))
    with JsonlLog(tmp_path / "e.jsonl", seed=1, config={}, params=CLASSIC.to_dict()) as log:
        log.write(EPISODES[0])
        log.write(short)
    lines = [json.loads(line) for line in (tmp_path / "e.jsonl").read_text().splitlines()]
    assert lines[1]["missed"] == {} and lines[2]["missed"] == {"keeper 2": 25, "taker 1": 3}
    assert read_jsonl(tmp_path / "e.jsonl")[1] == [EPISODES[0], short]


def test_a_log_written_before_missed_existed_reads_as_full_episodes(tmp_path):
    path, log = _jsonl(tmp_path)
    log.close()
    old = [json.loads(line) for line in path.read_text().splitlines()]
    for entry in old[1:]:
        del entry["missed"]
    path.write_text("".join(json.dumps(entry) + "\n" for entry in old))
    assert read_jsonl(path)[1] == EPISODES
    assert all(e.missed == () for e in read_jsonl(path)[1])


def test_a_new_log_sets_an_earlier_one_aside_instead_of_overwriting_it(tmp_path):
    for run in range(3):
        with KwyLog(tmp_path, 3, 2, 20.0, 20.0, fixed_name="keepaway") as kwy:
            kwy.write(EPISODES[run])
        with JsonlLog(tmp_path / "keepaway.jsonl", seed=run, config={}, params=CLASSIC.to_dict()) as jsonl:
            jsonl.write(EPISODES[run])
    # the newest log under the plain name, the earlier ones numbered in the order they were set aside
    for name, run in [("keepaway", 2), ("keepaway.1", 0), ("keepaway.2", 1)]:
        header, episodes = read_jsonl(tmp_path / f"{name}.jsonl")
        assert (header["seed"], episodes) == (run, [EPISODES[run]])
        kwy_lines = (tmp_path / f"{name}.kwy").read_text().splitlines()
        assert kwy_lines[0] == "# Keepers: 3" and kwy_lines[-1].startswith(f"{EPISODES[run].episode}\t")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"{n}.{ext}" for n in ("keepaway", "keepaway.1", "keepaway.2") for ext in ("kwy", "jsonl"))


def test_an_unfixed_kwy_never_renames_over_another_log(tmp_path, monkeypatch):
    import keepaway.server.episode_log as episode_log
    moment = time.localtime()
    monkeypatch.setattr(episode_log.time, "localtime", lambda: moment)  # both opened in the same second
    paths = []
    for record in EPISODES[:2]:
        with KwyLog(tmp_path, 3, 2, 20.0, 20.0) as log:
            log.write(record)
        paths.append(log.path)
    assert paths[1] == paths[0].with_name(paths[0].stem + ".1.kwy")
    assert [p.read_text().splitlines()[-1][0] for p in paths] == ["1", "2"]


def test_free_name_numbers_past_the_taken_names(tmp_path):
    for name in ("k.jsonl", "k.1.jsonl", "k.3.jsonl"):
        (tmp_path / name).write_text("")
    assert free_name(tmp_path / "k.jsonl") == tmp_path / "k.2.jsonl"
    assert free_name(tmp_path / "other.jsonl") == tmp_path / "other.jsonl"
