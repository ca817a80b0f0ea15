"""``keepaway view`` and ``keepaway render``: the replay's rules (sans-IO), the page served over HTTP, and the
page in a real headless browser (Chromium from Debian's packages: ``apt-get install chromium
chromium-driver``; skipped, saying so, where there is none), replaying a game log and following a live
arena; the players move between two screenshots."""

from __future__ import annotations

import io
import re
import shutil
import subprocess
import time
import urllib.request
from pathlib import Path

import pytest

from conftest import keepaway_command, read_until_match
from keepaway.protocol import messages as m
from keepaway.server.episode_log import read_kwy
from keepaway.server.game_log import parse_rcg, read_rcg
from keepaway.viewer.frames import SPEEDS, Replay, live_frame
from keepaway.viewer.render import episode_shows

DATA = Path(__file__).parent / "data" / "rcss-behaviour"
REFERENCE = DATA / "ref_hold2_head.rcg"
URL_RE = re.compile(r"keepaway view: (http://127\.0\.0\.1:\d+/)\n")


def reference_with_episodes():
    lines = REFERENCE.read_text(encoding="latin-1").splitlines()
    marked = lines[:40] + ['(msg 17 1 "(referee training Keepaway 1)")'] + lines[40:]
    return parse_rcg(line + "\n" for line in marked)


def test_a_replay_plays_pauses_steps_changes_speed_and_jumps_to_an_episode():
    replay = Replay(reference_with_episodes())
    first = replay.frame()
    assert (first["cycle"], first["episode"], first["hold_s"], first["playing"]) == (0, 1, 0.0, True)
    assert len(first["players"]) == 5 and first["ball"] == [-6.0, -6.0]
    assert replay.advance() and replay.frame()["cycle"] == 1
    replay.command({"command": "episode", "value": 2})
    assert (replay.frame()["cycle"], replay.frame()["episode"], replay.frame()["hold_s"]) == (17, 2, 0.0)
    replay.command({"command": "step", "value": -3})
    assert (replay.frame()["cycle"], replay.frame()["episode"], replay.playing) == (14, 1, False)
    assert not replay.advance()
    replay.command({"command": "speed", "value": 4.0})
    assert replay.interval_s == pytest.approx(0.025)
    replay.command({"command": "seek", "value": 1000})
    replay.command({"command": "play"})
    assert replay.frame()["cycle"] == 39 and not replay.advance() and not replay.playing  # the end pauses
    for bad, text in [({"command": "speed", "value": 3}, "speed must be one of"),
                      ({"command": "episode", "value": 3}, r"episode must be in 1\.\.2"),
                      ({"command": "step", "value": "x"}, "step needs an integer"),
                      ({"command": "fly"}, "unknown command"), ([1], "a request is a map")]:
        with pytest.raises(ValueError, match=text):
            replay.command(bad)
    assert 1.0 in SPEEDS


def start_viewer(processes, *args: str) -> tuple[subprocess.Popen, str]:
    proc = processes.popen(keepaway_command("view", "--port", "0", *args), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE)
    return proc, read_until_match(proc.stdout, URL_RE, 60).group(1)


def test_a_live_frame_knows_the_hold_time_of_an_episode_joined_midway():
    frame = m.Frame(cycle=57, ball=(0.0, 0.0, 0.0, 0.0), players=(), play_mode="play_on", episode=3,
                    episode_start=40, take_count=0)
    page = live_frame(frame, step_ms=100.0)
    assert (page["cycle"], page["episode"], page["hold_s"]) == (57, 3, 1.7)


def test_view_prints_its_url_and_serves_the_page(processes, tmp_path):
    proc, url = start_viewer(processes, str(REFERENCE))
    with urllib.request.urlopen(url, timeout=10) as response:
        assert response.status == 200 and response.headers.get_content_type() == "text/html"
        assert b"<canvas id=\"players\">" in response.read()
    processes.kill(proc)


def test_view_and_render_refuse_bad_input_in_one_line(processes, tmp_path):
    bad = tmp_path / "bad.rcg"
    bad.write_text("ULG4\n")
    for args, text in [(["view", str(bad)], "not a text game log of version 5"),
                       (["view", str(tmp_path / "none.rcg")], "cannot read"),
                       (["view"], "give a game log to replay or --server"),
                       (["view", "--server", "localhost:5"], "--server: not a tcp:// endpoint"),
                       (["render", str(REFERENCE), "--episode", "9", "-o", str(tmp_path / "x.gif")],
                        "episodes 1..2, not 9"),
                       (["render", str(REFERENCE), "-o", str(tmp_path / "x.png")], "must end in .gif or .mp4")]:
        proc = processes.popen(keepaway_command(*args), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode in (1, 2), err
        assert text in err.decode() and "Traceback" not in err.decode(), err.decode()


def test_a_runs_game_log_has_the_episodes_it_played_and_render_refuses_the_next(processes, tmp_path):
    """The referee's message after the last episode starts no episode: five played, five replayed, each
    drawn from its start to the cycle before its end, and a sixth refused naming the range."""
    run = processes.popen(keepaway_command("run", "--mode", "embedded", "--episodes", "5", "--seed", "3",
                                           "--no-progress", "--out", str(tmp_path)),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, err = run.communicate(timeout=600)
    assert run.returncode == 0, err.decode()[-2000:]
    record = read_rcg(tmp_path / "keepaway.rcg")
    episodes = read_kwy(tmp_path / "keepaway.kwy")
    assert record.episode_starts == [e.start_cycle for e in episodes]
    assert record.episodes_end == episodes[-1].end_cycle == record.shows[-1].cycle
    assert Replay(record).info("keepaway.rcg")["episodes"] == 5
    assert len(episode_shows(record, 5)) == episodes[-1].end_cycle - episodes[-1].start_cycle
    proc = processes.popen(keepaway_command("render", str(tmp_path / "keepaway.rcg"), "--episode", "6",
                                            "-o", str(tmp_path / "e6.gif")),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1 and err.decode().strip().splitlines() == [
        "Error: the game log has episodes 1..5, not 6"]
    assert not (tmp_path / "e6.gif").exists()


def test_render_draws_an_episode_to_a_gif_and_an_mp4(tmp_path):
    from PIL import Image

    from keepaway.viewer.render import render

    record = read_rcg(REFERENCE, kwy=DATA / "ref_hold2_head.kwy")
    assert render(record, 2, tmp_path / "e2.gif") == 15  # cycles 25..39 of the log
    with Image.open(tmp_path / "e2.gif") as gif:
        assert gif.n_frames == 15
        gif.seek(0)
        first = gif.convert("RGB").tobytes()
        gif.seek(14)
        assert gif.convert("RGB").tobytes() != first  # the players moved
    pytest.importorskip("imageio_ffmpeg", reason="MP4 needs the render extra (imageio-ffmpeg)")
    assert render(record, 1, tmp_path / "e1.mp4") == 25
    assert (tmp_path / "e1.mp4").stat().st_size > 1000


# -- a real browser ----------------------------------------------------------------------------------
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.fixture
def browser():
    if CHROMIUM is None or CHROMEDRIVER is None:
        pytest.skip("no headless browser: install Debian's chromium and chromium-driver "
                    "(apt-get install chromium chromium-driver) to test the viewer page")
    webdriver = pytest.importorskip("selenium.webdriver", reason="the test extra's selenium drives the browser")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1000,900"):
        options.add_argument(arg)
    driver = webdriver.Chrome(options=options, service=Service(CHROMEDRIVER))
    try:
        yield driver
    finally:
        driver.quit()


def players_layer(driver) -> bytes:
    from PIL import Image

    png = driver.find_element("id", "players").screenshot_as_png
    return Image.open(io.BytesIO(png)).convert("RGB").tobytes()


def watch(driver, url: str, timeout_s: float = 60.0) -> tuple[bytes, bytes, str, str]:
    """Open the page, wait for a frame, take the players' layer twice a second apart; also the cycles."""
    driver.get(url)
    deadline = time.monotonic() + timeout_s
    while driver.find_element("id", "cycle").text in ("", "-"):
        assert time.monotonic() < deadline, driver.find_element("id", "status").text
        time.sleep(0.1)
    first, cycle1 = players_layer(driver), driver.find_element("id", "cycle").text
    time.sleep(1.0)
    second, cycle2 = players_layer(driver), driver.find_element("id", "cycle").text
    return first, second, cycle1, cycle2


def test_the_page_replays_a_game_log_in_a_real_browser(processes, browser):
    _, url = start_viewer(processes, str(REFERENCE))
    first, second, cycle1, cycle2 = watch(browser, url)
    assert int(cycle2) > int(cycle1)
    assert first != second  # the players moved
    assert browser.find_element("id", "episode").text == "1"
    browser.find_element("id", "play").click()  # pause
    time.sleep(0.5)
    assert browser.find_element("id", "play").text == "play"
    paused = browser.find_element("id", "cycle").text
    time.sleep(0.5)
    assert browser.find_element("id", "cycle").text == paused


def test_the_page_draws_the_keepers_getopen_notes_in_a_real_browser(processes, tmp_path, browser):
    """A game log with the keepers' notes (targets and the grid points' values): the page draws the
    values when asked to, over the same frame."""
    log = processes.popen(keepaway_command("run", "--mode", "embedded", "--episodes", "1", "--getopen-notes",
                                           "values", "--no-progress", "--out", str(tmp_path)))
    assert log.wait(300) == 0
    _, url = start_viewer(processes, str(tmp_path / "keepaway.rcg"))
    watch(browser, url)
    browser.find_element("id", "play").click()  # pause
    deadline = time.monotonic() + 60
    while not browser.execute_script("return last && !last.playing && last.getopen.length > 0"):
        assert time.monotonic() < deadline, "no paused frame with notes"
        browser.find_element("id", "forward").click()
        time.sleep(0.2)
    notes = browser.execute_script("return last.getopen")
    assert all(len(target) == 2 and len(values) % 3 == 0 for _, target, values in notes)
    plain = players_layer(browser)
    browser.find_element("id", "grid").click()
    assert players_layer(browser) != plain  # the grid values are drawn


def test_run_view_shows_its_live_arena_in_a_real_browser(processes, tmp_path, browser):
    """``keepaway run --view``: a real distributed arena (server, coach, five players) in real time, and
    the viewer it starts follows the arena's monitor port."""
    run = processes.popen(keepaway_command("run", "--view", "--realtime", "--episodes", "1000", "--no-progress",
                                           "--out", str(tmp_path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    url = read_until_match(run.stderr, re.compile(r"watch the arena at (http://127\.0\.0\.1:\d+/)\n"), 180).group(1)
    first, second, cycle1, cycle2 = watch(browser, url, timeout_s=120)
    assert int(cycle2) > int(cycle1)
    assert first != second
    assert browser.find_element("id", "mode").text.startswith("live tcp://")
    # --view asks the keepers for their GetOpen notes, which come with the live frames
    deadline = time.monotonic() + 60
    while not browser.execute_script("return last.getopen.some(([u, t, values]) => values.length > 0)"):
        assert time.monotonic() < deadline, "no live frame with GetOpen notes"
        time.sleep(0.2)
