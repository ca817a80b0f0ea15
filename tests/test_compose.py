"""docker-compose.yml cannot run on CI (no Docker engine): check that it parses, that it has the arena's
services wired by service names, and that every service's command is a valid ``keepaway`` invocation."""

from __future__ import annotations

import re
from pathlib import Path

import click
import pytest
import yaml

from keepaway.cli import main

REPO = Path(__file__).resolve().parent.parent
COMPOSE = yaml.safe_load((REPO / "docker-compose.yml").read_text())
SERVICES = COMPOSE["services"]


def test_compose_has_the_arena_services_and_a_trainer_profile():
    assert {"server", "coach", "keeper1", "keeper2", "keeper3", "taker1", "taker2"} <= set(SERVICES)
    assert SERVICES["trainer"]["profiles"] == ["train"]
    assert all(s.get("image") == "keepaway:latest" for s in SERVICES.values())
    assert "ENTRYPOINT [\"keepaway\"]" in (REPO / "Dockerfile").read_text()


@pytest.mark.parametrize("name", sorted(SERVICES))
def test_service_command_is_a_valid_keepaway_invocation(name):
    argv = SERVICES[name]["command"]
    command = main.get_command(click.Context(main), argv[0])
    assert command is not None, f"{name}: unknown subcommand {argv[0]}"
    command.make_context(argv[0], list(argv[1:]))  # raises click.UsageError on a bad option


def test_the_trainer_drives_the_compose_arena_through_its_coach():
    argv = SERVICES["trainer"]["command"]
    coach = SERVICES["coach"]["command"]
    assert argv[argv.index("--mode") + 1] == "distributed"
    assert argv[argv.index("--arena") + 1] == f"tcp://coach:{coach[coach.index('--arena-port') + 1]}"


@pytest.mark.parametrize("name", ["coach", "keeper1", "taker2"])
def test_clients_reach_the_server_by_service_name(name):
    argv = SERVICES[name]["command"]
    endpoint = argv[argv.index("--server") + 1]
    assert endpoint.startswith("tcp://server:")


def test_the_image_holds_every_package_and_its_compiled_kernels():
    import tomllib

    setuptools = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = ["keepaway", *setuptools["package-dir"].values()]  # the keepaway namespace's folders
    assert len(folders) == len(setuptools["packages"])
    dockerfile = (REPO / "Dockerfile").read_text()
    for folder in folders:
        assert f"COPY {folder} ./{folder}\n" in dockerfile, f"the image lacks the package folder {folder}"
    command = main.get_command(click.Context(main), "compile")
    assert command is not None and "keepaway compile" in dockerfile


@pytest.mark.parametrize("name", [name for name in sorted(SERVICES) if SERVICES[name].get("ports")])
def test_published_ports_are_bound_to_loopback_unless_configured(name):
    for mapping in SERVICES[name]["ports"]:
        assert re.fullmatch(r"\$\{KEEPAWAY_PUBLISH_HOST:-127\.0\.0\.1\}:\d+:\d+", mapping), \
            f"{name} publishes {mapping} beyond loopback by default"
