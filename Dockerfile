# kfio HTTP service.  Build: docker build -t kfio .   Run: docker run -p 8000:8000 kfio
# (No Docker engine runs on the development machines: tests/test_service_docker.py
# replays the install and start commands below in a fresh virtual environment.)
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    MPLCONFIGDIR=/tmp/matplotlib

RUN useradd --create-home --uid 10001 --shell /usr/sbin/nologin kfio

WORKDIR /opt/kfio
COPY pyproject.toml README.md ./
COPY analyzer ./analyzer
COPY service ./service
RUN pip install --no-cache-dir .

USER kfio
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=3s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=2)"]
# Inside the container every name is trusted: the host name clients use is only known where the
# container is published.  A deployment should name it, e.g. -e KFIO_TRUSTED_HOSTS=kfio.example.org
# (any other Host header is then 421), which also keeps DNS-rebinding pages out (docs/service.md).
ENV KFIO_TRUSTED_HOSTS="*"
CMD ["kfio", "serve", "--host", "0.0.0.0", "--port", "8000"]
