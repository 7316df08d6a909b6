# kfio HTTP service and CLI, with python-control and the sweep engine (extras control, sweep).
#   Build: scripts/container.sh (buildah), or
#          docker build --build-arg VERSION=$(python -c "import kfio; print(kfio.__version__)") \
#                       --build-arg REVISION=$(git rev-parse HEAD) -t kfio .
#   Run:   docker run -p 8000:8000 kfio      (another port: -e KFIO_PORT=9000 -p 9000:9000)
# Two stages: the builder makes kfio's wheel and installs it, with every dependency at the
# version pinned in constraints.txt (scripts/constraints.py), into the virtual environment
# /opt/kfio; the runtime stage copies that environment alone onto a fresh base image, so
# no compiler, wheel or pip cache ends up in the image.
# (No Docker engine runs on the development machines: tests/test_service_docker.py replays
# the install and start commands in a fresh virtual environment, and tests/test_dockerfile.py
# checks this file's invariants; scripts/container.sh builds and runs the image with buildah.)
ARG BASE_IMAGE=python:3.11-slim

FROM ${BASE_IMAGE} AS builder
# Behind a TLS-inspecting proxy, pip needs its CA bundle: scripts/container.sh mounts the
# host's for the build and names it here (a build argument: nothing of it stays in the image).
ARG PIP_CERT
ENV PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /src
COPY constraints.txt pyproject.toml README.md LICENSE ./
COPY analyzer ./analyzer
COPY service ./service
RUN python -m venv /opt/kfio
RUN /opt/kfio/bin/pip wheel --no-deps --wheel-dir /dist .
RUN /opt/kfio/bin/pip install --constraint constraints.txt "$(ls /dist/kfio-*.whl)[control,sweep]"
# What a server never runs: the test suites of the largest dependencies, pip itself, and SCS's
# optional MKL build (110 MB; SCS falls back to its bundled QDLDL, and kfio's LMIs use Clarabel).
RUN /opt/kfio/bin/pip uninstall --yes pip \
    && rm -f /opt/kfio/lib/python3*/site-packages/scs/_scs_mkl.*.so \
    && find /opt/kfio -depth -type d -name tests -path "*/site-packages/*" \
        \( -path "*/numpy/*" -o -path "*/scipy/*" -o -path "*/pyarrow/*" -o -path "*/matplotlib/*" \
           -o -path "*/sympy/*" \) -exec rm -rf {} +

FROM ${BASE_IMAGE}
ARG VERSION=unknown
ARG REVISION=unknown
ARG SOURCE=unknown
LABEL org.opencontainers.image.title="kfio" \
      org.opencontainers.image.description="Stability analyzer for Kalman filters whose measurements travel over lossy networks" \
      org.opencontainers.image.source="${SOURCE}" \
      org.opencontainers.image.version="${VERSION}" \
      org.opencontainers.image.revision="${REVISION}" \
      org.opencontainers.image.licenses="MIT"

# Settings of the service (docs/service.md): one variable a line, add more here.
ENV PATH=/opt/kfio/bin:$PATH \
    PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    MPLCONFIGDIR=/tmp/matplotlib \
    KFIO_HOST=0.0.0.0 \
    KFIO_PORT=8000

# The job database lives in kfio serve's default data directory (KFIO_DATA_DIR): a volume, so that
# accepted jobs and their results outlive the container (docs/deployment.md).
RUN useradd --create-home --uid 10001 --shell /usr/sbin/nologin kfio \
    && install -d -o kfio -g kfio -m 700 /home/kfio/.local /home/kfio/.local/share /home/kfio/.local/share/kfio
COPY --from=builder /opt/kfio /opt/kfio
VOLUME ["/home/kfio/.local/share/kfio"]

USER 10001
WORKDIR /home/kfio
EXPOSE 8000
# Shell form, so the check follows KFIO_PORT (docker run -e KFIO_PORT=9000); python's urllib, no curl.
HEALTHCHECK --interval=30s --timeout=3s --start-period=30s --retries=3 \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:${KFIO_PORT:-8000}/healthz', timeout=2)" || exit 1
# Inside the container every name is trusted: the host name clients use is only known where the
# container is published.  A deployment should name it, e.g. -e KFIO_TRUSTED_HOSTS=kfio.example.org
# (any other Host header is then 421), which also keeps DNS-rebinding pages out (docs/service.md).
ENV KFIO_TRUSTED_HOSTS="*"
# Access: the server listens on all addresses, so with no token configured it generates one at start and
# prints it in the container's log (docker logs ...: "Authorization: Bearer ..."), new at every start.
# Choose the tokens: -e KFIO_API_TOKEN=... (one client), or KFIO_API_TOKEN_FILE=/run/secrets/kfio-tokens
# (a mounted file, one token per line, several clients). KFIO_AUTH=none serves without any, for a reverse
# proxy in front that authenticates. /healthz (and so the HEALTHCHECK) needs no token (docs/deployment.md).
ENV KFIO_AUTH=auto
# kfio serve reads KFIO_HOST and KFIO_PORT (and every other KFIO_ setting) from the environment.
CMD ["kfio", "serve"]
