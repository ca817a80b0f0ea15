"""`keepaway train --backend ray`: arenas placed by Ray (a local Ray here), driven like any other.

Ray is an optional extra (`pip install 'keepaway[ray]'`): without it this module is skipped, and the
CLI test checks the one-line error instead.
"""

from __future__ import annotations

import importlib.util

import pytest
from click.testing import CliRunner

from keepaway.cli import main
from runner.job import Behaviours
from trainer.train import TrainConfig

HAVE_RAY = importlib.util.find_spec("ray") is not None


@pytest.mark.skipif(HAVE_RAY, reason="checks the message shown when Ray is missing")
def test_without_ray_the_backend_is_refused_in_one_line(tmp_path):
    done = CliRunner().invoke(main, ["train", "--mode", "distributed", "--backend", "ray", "--out", str(tmp_path / "t")])
    assert done.exit_code == 2
    assert "pip install 'keepaway[ray]'" in done.output


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_ray_places_arenas_that_play_like_local_ones(tmp_path):
    import ray

    from runner.distributed import DistributedBackend
    from runner.ray_backend import ray_launcher

    config = TrainConfig(mode="distributed", arenas=2)
    job = Behaviours("random", "handcoded")
    try:
        backend = ray_launcher(None)(config.game(), config.parameter_set, config.arenas, config.chunk_episodes)
        try:
            on_ray = backend.play(job, 21, 4, "greedy")[0]
        finally:
            backend.close()
    finally:
        ray.shutdown()
    with DistributedBackend.start_local(config.game(), 1, tmp_path, "classic") as local:
        here = local.play(job, 21, 4, "greedy")[0]
    assert [(e.end_cycle - e.start_cycle, e.end) for e in on_ray.episodes] == \
        [(e.end_cycle - e.start_cycle, e.end) for e in here.episodes]
