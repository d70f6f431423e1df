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


def _compose() -> dict:
    return yaml.safe_load((REPO / "docker-compose.yml").read_text())


def test_the_worker_has_its_own_celery_healthcheck():
    worker = _compose()["services"]["worker"]
    test = worker["healthcheck"]["test"]
    command = test[1] if test[0] == "CMD-SHELL" else " ".join(test[1:])
    # not the API's HTTP check inherited from the image: a ping of this worker's node over the broker
    assert "celery" in command and "inspect ping" in command and "$$BROKER_URL" in command
    assert "--destination \"celery@$$HOSTNAME\"" in command and "/healthz" not in command
    assert "--hostname" not in worker["command"]  # so the node is named celery@<container hostname>


def test_every_long_running_service_restarts_and_the_one_shot_migration_does_not():
    services = _compose()["services"]
    for name in ("postgres", "redis", "api", "worker"):
        assert services[name]["restart"] == "unless-stopped", name
    assert services["migrate"]["restart"] == "no"


def test_the_postgres_password_comes_from_the_environment():
    text = (REPO / "docker-compose.yml").read_text()
    services = _compose()["services"]
    assert services["postgres"]["environment"]["POSTGRES_PASSWORD"].startswith("${POSTGRES_PASSWORD:?")
    for name in ("api", "worker", "migrate"):
        url = services[name]["environment"]["DATABASE_URL"]
        assert "${POSTGRES_PASSWORD:?" in url and ":plantsolve@" not in url
    assert "POSTGRES_PASSWORD: plantsolve" not in text
    example = (REPO / ".env.example").read_text()
    assert "POSTGRES_PASSWORD=" in example and "API_KEYS=" in example
    assert ".env" in (REPO / ".gitignore").read_text().split()


def test_the_image_keeps_no_wheels_and_the_context_no_local_environment():
    text = (REPO / "Dockerfile").read_text()
    runtime = text[text.index("AS runtime"):]
    assert "COPY --from=build /opt/venv /opt/venv" in runtime
    assert "wheel" not in runtime.lower() and "pip install" not in runtime  # nothing installed (or left) at run time
    assert "PATH=/opt/venv/bin" in runtime
    ignored = {line.strip() for line in (REPO / ".dockerignore").read_text().splitlines()
               if line.strip() and not line.startswith("#")}
    assert {".venv", ".git", "var", ".env", "tests"} <= ignored
    # what the build copies is not ignored
    copied = {"pyproject.toml", "README.md", "plantsolve"}
    assert not copied & ignored


def test_api_keys_unset_on_a_public_address_is_logged_loudly(tmp_path, caplog):
    import logging

    from fastapi.testclient import TestClient

    from plantsolve.app.auth import KeyRing, warn_if_exposed
    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    caplog.set_level(logging.WARNING, logger="plantsolve")
    assert warn_if_exposed("0.0.0.0", KeyRing([], [])) and "API_KEYS is empty" in caplog.text
    caplog.clear()
    assert not warn_if_exposed("127.0.0.1", KeyRing([], [])) and not warn_if_exposed("::1", KeyRing([], []))
    assert not warn_if_exposed("0.0.0.0", KeyRing(["k"], []))
    assert not caplog.records
    # as served: each request names the server address it arrived on; loopback ones (a container's own health
    # check) are quiet, the first on another address (a published port) warns, once
    app = create_app(service_settings(tmp_path), run_jobs=False)
    reached = {"server": ("127.0.0.1", 8000)}

    async def served_on(scope, receive, send):  # the server address uvicorn puts in each request's scope
        if scope["type"] == "http":
            scope = {**scope, "server": reached["server"]}
        await app(scope, receive, send)

    with TestClient(served_on) as client:
        for address in ("127.0.0.1", "127.0.0.1", "172.18.0.5", "172.18.0.5"):
            reached["server"] = (address, 8000)
            client.get("/healthz")
            if address == "127.0.0.1":
                assert not [r for r in caplog.records if "API_KEYS is empty" in r.getMessage()]
    warnings = [r for r in caplog.records if "API_KEYS is empty" in r.getMessage()]
    assert len(warnings) == 1 and "172.18.0.5" in warnings[0].getMessage()
    caplog.clear()
    with TestClient(create_app(service_settings(tmp_path / "keyed", api_keys=["k"]), run_jobs=False)) as client:
        client.get("/healthz")
    assert not [r for r in caplog.records if "API_KEYS is empty" in r.getMessage()]

