#!/usr/bin/env bash
# Build the kfio image with buildah, run it, and try what a user would: /healthz (and the
# image's own HEALTHCHECK command), an analysis, a sweep over HTTP and `kfio sweep` (Dask) inside;
# then print the image size.  Needs root and buildah; no Docker daemon.
#
#   scripts/container.sh                        # base image python:3.11-slim
#   BASE_IMAGE=localhost/python:3.11-slim scripts/container.sh
#
# Where no registry of container images can be reached, scripts/standin-base.sh builds a
# stand-in base image (Debian bookworm and its Python 3.11) first; STANDIN=1 does that here.
# Settings: BUILD=0 reuses an image already built, IMAGE (default kfio:<version>), PORT (default 8765: not the image's 8000, so the
# server and the HEALTHCHECK must follow KFIO_PORT), SOURCE (the OCI source label).
set -euo pipefail
cd "$(dirname "$0")/.."

. scripts/vfs-storage.sh      # vfs storage (CONTAINERS_STORAGE_CONF names another store)
BASE_IMAGE="${BASE_IMAGE:-python:3.11-slim}"
PORT="${PORT:-8765}"
VERSION="$(sed -n 's/^__version__ = "\(.*\)"/\1/p' analyzer/_version.py)"
REVISION="$(git rev-parse HEAD 2>/dev/null || echo unknown)"
git diff --quiet HEAD -- 2>/dev/null || REVISION="$REVISION-dirty"   # uncommitted changes are built too
SOURCE="${SOURCE:-$(git config --get remote.origin.url 2>/dev/null || echo unknown)}"
IMAGE="${IMAGE:-localhost/kfio:$VERSION}"
URL="http://127.0.0.1:$PORT"
# The image listens on all addresses, so kfio serve would generate an access token; this run sets its own.
export KFIO_API_TOKEN="${KFIO_API_TOKEN:-$(python3 -c 'import secrets; print(secrets.token_urlsafe(32))')}"

if [ "${STANDIN:-0}" = 1 ] && ! buildah inspect --type image "$BASE_IMAGE" >/dev/null 2>&1; then
    scripts/standin-base.sh "$BASE_IMAGE"
fi

# pip's CA bundle on this machine (PIP_CERT, or pip's configured cert), lent to the build's RUN steps
ca="${PIP_CERT:-$(pip config get global.cert 2>/dev/null || true)}"
ca_args=()
if [ -n "$ca" ] && [ -f "$ca" ]; then
    ca_args=(--volume "$ca:/run/build-ca.crt:ro" --build-arg PIP_CERT=/run/build-ca.crt)
fi

echo "== build $IMAGE from $BASE_IMAGE (revision $REVISION)"
start=$(date +%s)
[ "${BUILD:-1}" = 0 ] && buildah inspect --type image "$IMAGE" >/dev/null 2>&1 && echo "(BUILD=0: reusing $IMAGE)" \
|| buildah bud --isolation chroot --format docker --layers=false \
    --build-arg BASE_IMAGE="$BASE_IMAGE" --build-arg VERSION="$VERSION" \
    --build-arg REVISION="$REVISION" --build-arg SOURCE="$SOURCE" "${ca_args[@]}" \
    -f Dockerfile -t "$IMAGE" .
build_s=$(( $(date +%s) - start ))

ctr="$(buildah from "$IMAGE")"
server=""
cleanup() {
    # the server's process id, as the container wrote it (chroot isolation shares the host's process ids)
    if [ -n "$server" ]; then
        pid="$(cat "$(buildah mount "$ctr")/tmp/kfio-serve.pid" 2>/dev/null || true)"
        [ -n "$pid" ] && kill "$pid" 2>/dev/null || true
        wait "$server" 2>/dev/null || true
    fi
    buildah rm "$ctr" >/dev/null 2>&1 || true
}
trap cleanup EXIT
run() { buildah run --isolation chroot --env KFIO_PORT="$PORT" "$ctr" -- "$@"; }

echo "== image configuration"
buildah inspect --type image --format \
    'user {{.OCIv1.Config.User}}, cmd {{.OCIv1.Config.Cmd}}, healthcheck {{.Docker.Config.Healthcheck.Test}}' "$IMAGE"
buildah inspect --type image --format '{{range $k, $v := .OCIv1.Config.Labels}}label {{$k}}={{$v}}{{println}}{{end}}' \
    "$IMAGE"
echo "uid in the container: $(run id -u)"
run python -c "import control, dask.distributed, pyarrow, tqdm, kfio; print('kfio', kfio.__version__, \
'with python-control', control.__version__, 'dask', dask.__version__, 'pyarrow', pyarrow.__version__)"

echo "== kfio serve on port $PORT (KFIO_PORT)"
# the image's CMD, as the container runtime would start it
mapfile -t cmd < <(buildah inspect --type image --format '{{range .OCIv1.Config.Cmd}}{{println .}}{{end}}' "$IMAGE" | sed '/^$/d')
buildah run --isolation chroot --env KFIO_PORT="$PORT" --env KFIO_API_TOKEN="$KFIO_API_TOKEN" "$ctr" -- \
    sh -c 'echo $$ > /tmp/kfio-serve.pid && exec "$@"' sh "${cmd[@]}" &
server=$!
python3 - "$URL" <<'PY'
import sys, time, urllib.request
for _ in range(240):
    try:
        print("GET /healthz:", urllib.request.urlopen(sys.argv[1] + "/healthz", timeout=2).read().decode())
        break
    except OSError:
        time.sleep(0.5)
else:
    sys.exit("the server did not answer /healthz in 120 s")
PY
health="$(buildah inspect --type image --format '{{index .Docker.Config.Healthcheck.Test 1}}' "$IMAGE")"
run sh -c "$health" && echo "HEALTHCHECK command (run inside, KFIO_PORT=$PORT): healthy"

echo "== analyze and sweep over HTTP"
python3 - "$URL" examples/seed004_scalar.json <<'PY'
import json, os, sys, time, urllib.request

url, example = sys.argv[1], sys.argv[2]
headers = {"Content-Type": "application/json", "Authorization": "Bearer " + os.environ["KFIO_API_TOKEN"]}

def call(path, body=None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(path if path.startswith("http") else url + path, data=data, headers=headers)
    with urllib.request.urlopen(req, timeout=120) as r:
        return r.status, json.loads(r.read())

t = time.monotonic()
status, rep = call("/v1/analyze", json.load(open(example)))
print(f"POST /v1/analyze {example}: {status}, verdict {rep['verdict']}, "
      f"critical arrival probability {rep['critical_arrival_probability_exact']} ({time.monotonic() - t:.1f} s)")
sweep = {
    "command": "analyze",
    "base": json.load(open(example)),
    "axes": [{"pointer": "/channel/arrival_probability", "from": "1/10", "to": "9/10", "num": 9}],
}
t = time.monotonic()
status, job = call("/v1/sweeps", sweep)
while True:
    status, job = call(job["links"]["self"])
    if job["status"] not in ("queued", "running"):
        break
    time.sleep(0.5)
rows = job.get("result", {}).get("rows") or []
print(f"POST /v1/sweeps (9 points): job {job['status']}, {len(rows)} rows, "
      f"verdicts {[r.get('verdict') for r in rows]} ({time.monotonic() - t:.1f} s)")
if job["status"] != "done" or len(rows) != 9:
    sys.exit(json.dumps(job)[:2000])
PY

echo "== kfio sweep inside the container (Dask LocalCluster, the default engine)"
cat > /tmp/kfio-container-sweep.json <<JSON
{"command": "analyze", "base": $(cat examples/seed004_scalar.json),
 "axes": [{"pointer": "/channel/arrival_probability", "from": "1/10", "to": "9/10", "num": 9}]}
JSON
buildah copy --chown 10001:10001 "$ctr" /tmp/kfio-container-sweep.json /tmp/sweep.json >/dev/null
rm -f /tmp/kfio-container-sweep.json
run sh -c 'cd /tmp && kfio sweep sweep.json --out table.csv && head -4 table.csv'

echo "== summary"
size="$(buildah images --format '{{.Size}}' "$IMAGE" | head -1)"
echo "image $IMAGE: $size, built in ${build_s} s from $BASE_IMAGE"
