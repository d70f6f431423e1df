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



# ---- reproducible installs: the lock files, the extras, one image --------------------------------

LOCKS = ("service", "image", "test")


def _pins(name: str) -> dict[str, str]:
    """Package -> version of requirements/<name>.txt, checking that each is pinned exactly with hashes."""
    import re

    text = (REPO / "requirements" / f"{name}.txt").read_text()
    pins: dict[str, str] = {}
    for block in re.split(r"\n(?=\S)", text):
        first = block.splitlines()[0]
        if first.startswith("#") or not first.strip():
            continue
        requirement = re.match(r"([A-Za-z0-9_.\-]+)(\[[^\]]*\])?==([^\s;\\]+)", first)
        assert requirement, f"requirements/{name}.txt: {first!r} is not pinned with =="
        assert "--hash=sha256:" in block, f"requirements/{name}.txt: {first!r} has no hash"
        pins[requirement.group(1).lower().replace("_", "-")] = requirement.group(3)
    return pins


def _names(requirements: list[str]) -> set[str]:
    import re

    return {re.match(r"[A-Za-z0-9_.\-]+", r).group(0).lower().replace("_", "-") for r in requirements}


def test_the_lock_files_pin_every_dependency_and_agree():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    pins = {name: _pins(name) for name in LOCKS}
    kinds = set().union(*(_names(extras[group]) for group in ("scan", "fem", "lego", "ifc")))
    assert _names(project["dependencies"]) | kinds <= set(pins["service"])
    assert set(pins["service"]) | _names(extras["scaled"]) <= set(pins["image"])
    assert set(pins["image"]) | (_names(extras["test"]) - {"plantsolve"}) <= set(pins["test"])
    for name in ("service", "image"):  # a package shared by two sets has one version
        assert {p: v for p, v in pins[name].items() if pins["test"][p] != v} == {}, name
    # the embedded default carries no test tools and no scaled-mode libraries
    assert not {"pytest", "selenium", "schemathesis", "celery", "redis", "psycopg", "boto3"} & set(pins["service"])
    # the LAZ backend, the webhook signer, the CLI's progress bar, the generated client's formatter
    assert {"lazrs", "laspy", "standardwebhooks", "rich"} <= set(pins["service"]) and "ruff" in pins["test"]


def test_the_project_metadata_is_current():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert isinstance(project["license"], str)  # an SPDX expression, not the deprecated table
    every = project["dependencies"] + [r for group in project["optional-dependencies"].values() for r in group]
    assert sorted(_names(every)).count("httpx") == 1
    extras = project["optional-dependencies"]
    assert {"scan", "fem", "lego", "ifc", "kinds", "scaled", "test"} <= set(extras)
    assert _names(extras["ifc"]) == {"ifcopenshell"} and "python-fcl" in _names(extras["lego"])
    assert {"celery", "redis", "psycopg", "asyncpg", "boto3"} == _names(extras["scaled"])
    assert not {"celery", "redis", "psycopg", "ifcopenshell", "python-fcl"} & _names(project["dependencies"])


def test_make_installs_from_the_lock():
    makefile = (REPO / "Makefile").read_text()
    assert "-r requirements/$*.txt" in makefile and "--require-hashes" in makefile
    assert "run: install-service" in makefile and "install-service: $(VENV)/.installed-service" in makefile
    assert "test: install" in makefile and "install: $(VENV)/.installed-test" in makefile
    dockerfile = (REPO / "Dockerfile").read_text()
    assert "--require-hashes -r requirements/image.txt" in dockerfile
    ignored = {line.strip() for line in (REPO / ".dockerignore").read_text().splitlines()}
    assert "requirements" not in ignored and "requirements/image.txt" not in ignored


def test_the_embedded_default_starts_without_the_scaled_mode_libraries(tmp_path):
    """`make run` installs no Celery, Redis or psycopg: the app must not import them unless scaled."""
    import subprocess
    import sys

    script = (
        "import sys\n"
        "for name in ('celery', 'redis', 'psycopg', 'kombu', 'boto3', 'botocore'): sys.modules[name] = None  # as if not installed\n"
        "from plantsolve.app.main import create_app\n"
        "from plantsolve.app.settings import AppSettings\n"
        f"app = create_app(AppSettings(_env_file=None, data_dir={str(tmp_path)!r}), run_jobs=False)\n"
        "from plantsolve.solvers.kinds import KINDS\n"
        "assert len(KINDS) == 7, sorted(KINDS)\n"
    )
    done = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]


def test_compose_builds_one_image_that_every_plantsolve_service_uses():
    services = _compose()["services"]
    ours = ("api", "worker", "migrate")
    tags = {services[name]["image"] for name in ours}
    assert len(tags) == 1 and "plantsolve" in tags.pop()
    assert [name for name in services if "build" in services[name]] == ["api"]  # built once
    for name in ours:
        if "build" not in services[name]:
            assert services[name]["pull_policy"] == "never", name  # the built image, not a registry's


def test_compose_mounts_named_volumes_only_and_the_image_declares_none():
    compose = _compose()
    declared = set(compose["volumes"])
    for name, service in compose["services"].items():
        for mount in service.get("volumes", []):
            source = mount.split(":")[0] if isinstance(mount, str) else mount["source"]
            assert source in declared, f"{name}: {mount} is not a named volume"
    # a VOLUME in the image leaves an anonymous volume behind each container that mounts nothing there
    assert "\nVOLUME" not in "\n" + (REPO / "Dockerfile").read_text()
