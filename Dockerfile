# syntax=docker/dockerfile:1
# Multi-stage: the build stage installs plantsolve and its dependencies into a virtual environment;
# the runtime stage copies that environment alone (no wheels, no pip cache, no build tools).
# The versions are the lock's (requirements/image.txt: every kind plus scaled mode, with hashes), so
# two builds of one commit install the same packages. The dependencies are installed before the code
# is copied: a code change rebuilds one small layer.
FROM python:3.11-slim AS build
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 UV_PYTHON_DOWNLOADS=never UV_NO_CACHE=1
RUN pip install uv==0.13.8 && python -m venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH
WORKDIR /src
COPY requirements/image.txt ./requirements/image.txt
# compiled to bytecode here: the image's processes write none (PYTHONDONTWRITEBYTECODE) and would otherwise compile
# every module they import, seconds of CPU for each `plantsolve solve` and each worker
RUN uv pip install --python /opt/venv/bin/python --compile-bytecode --require-hashes -r requirements/image.txt
COPY pyproject.toml README.md ./
COPY plantsolve ./plantsolve
RUN uv pip install --python /opt/venv/bin/python --no-deps --compile-bytecode .

FROM python:3.11-slim AS runtime
ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 DATA_DIR=/data MPLBACKEND=Agg PATH=/opt/venv/bin:$PATH \
    OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
RUN useradd --create-home --uid 10001 plantsolve && mkdir -p /data && chown plantsolve /data
COPY --from=build /opt/venv /opt/venv
USER plantsolve
WORKDIR /home/plantsolve
# no VOLUME: compose mounts the named volume 'artifacts' at /data where it is needed (a VOLUME here
# would leave an anonymous volume behind every one-shot container, such as each 'migrate' run)
EXPOSE 8000
# the API's check; the worker service in docker-compose.yml replaces it with a Celery ping
HEALTHCHECK --interval=10s --timeout=3s --retries=5 \
  CMD python -c "import urllib.request,sys; sys.exit(0 if urllib.request.urlopen('http://127.0.0.1:8000/healthz').status == 200 else 1)"
CMD ["plantsolve", "serve", "--host", "0.0.0.0", "--port", "8000"]
