"""docker-compose.yml and Dockerfile cannot be run here (no Docker engine): check them by
structure instead, so a broken edit fails CI."""

from __future__ import annotations

import tomllib

import yaml

from tests.conftest import REPO


def test_compose_has_the_scaled_topology_with_healthchecks():
    compose = yaml.safe_load((REPO / "docker-compose.yml").read_text())
    services = compose["services"]
    assert {"api", "worker", "redis", "postgres"} <= set(services)
    for name in ("redis", "postgres", "api"):
        assert "test" in services[name]["healthcheck"]
    for name in ("api", "worker"):
        depends = services[name]["depends_on"]
        assert depends["postgres"]["condition"] == "service_healthy"
        assert depends["redis"]["condition"] == "service_healthy"
        environment = services[name]["environment"]
        assert environment["DATABASE_URL"].startswith("postgresql+psycopg://")
        assert environment["BROKER_URL"].startswith("redis://")
    assert services["worker"]["command"][:2] == ["plantsolve", "worker"]


def test_dockerfile_is_multi_stage_and_runs_the_console_script():
    text = (REPO / "Dockerfile").read_text()
    assert text.count("\nFROM ") + text.startswith("FROM ") >= 2 and "COPY --from=build" in text
    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["plantsolve"] == "plantsolve.cli:main"
    assert 'CMD ["plantsolve", "serve"' in text
