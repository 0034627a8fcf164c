#!/usr/bin/env bash
# Build the fmuid image with podman, run it, post a real `fit` job (model=msd) and check the result.
#
# The base image is made locally (no registry): debootstrap a minimal Debian bookworm with python3
# and import it into podman. Python packages come from wheels built on the host with `pip wheel`
# (pip inside a build step cannot verify the sandbox's certificate chain), installed --no-index.
# runc is used as the runtime with explicit ulimits (the default runtime fails on setrlimit here).
#
# Exit status 0 when the container answered correctly, or with a line "SKIPPED: <reason>" when a
# tool is truly missing (podman, debootstrap, a Debian mirror, a kernel that runs containers);
# 1 when the image or the service is broken.
set -euo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
IMAGE=localhost/fmuid:latest
BASE=localhost/debian-min:bookworm
WORK=${FMUID_CONTAINER_WORK:-/var/tmp/fmuid-container}
PODMAN=(podman --runtime runc)
ULIMITS=(--ulimit nofile=1024:1024 --ulimit nproc=1000:1000)
TOKEN=container-test-token
PYTHON=${PYTHON:-$REPO/.venv/bin/python}
[ -x "$PYTHON" ] || PYTHON=python3

skip() { echo "SKIPPED: $*"; exit 0; }
fail() { echo "FAILED: $*"; exit 1; }
log() { echo "[test-container] $*"; }

# ---- tools ----------------------------------------------------------------------------------
missing=()
for tool in podman buildah runc debootstrap; do command -v "$tool" >/dev/null || missing+=("$tool"); done
if [ ${#missing[@]} -gt 0 ]; then
    [ "$(id -u)" = 0 ] || skip "${missing[*]} missing and not root to install them"
    log "installing ${missing[*]}"
    if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
            podman buildah runc debootstrap >/dev/null; }; then
        skip "could not install ${missing[*]} with apt-get"
    fi
fi

# ---- base image: debootstrap a minimal bookworm with python3 --------------------------------
mkdir -p "$WORK"
if ! "${PODMAN[@]}" image exists "$BASE"; then
    ROOTFS=$WORK/rootfs
    rm -rf "$ROOTFS"
    log "debootstrap bookworm into $ROOTFS"
    debootstrap --variant=minbase --include=python3,python3-venv bookworm "$ROOTFS" \
        >"$WORK/debootstrap.log" 2>&1 \
        || skip "no Debian mirror reachable for the base image (see $WORK/debootstrap.log)"
    tar -C "$ROOTFS" -c . | "${PODMAN[@]}" import - "$BASE" >/dev/null \
        || fail "podman import of the base image failed"
    rm -rf "$ROOTFS"
fi
"${PODMAN[@]}" run --rm "${ULIMITS[@]}" --network host "$BASE" python3 -c 'print("ok")' \
    >/dev/null 2>"$WORK/probe.log" || skip "podman cannot run containers here: $(tail -1 "$WORK/probe.log")"

# ---- build context: sources + wheels made on the host ---------------------------------------
CTX=$WORK/context
rm -rf "$CTX" && mkdir -p "$CTX"
cp -r "$REPO/pyproject.toml" "$REPO/README.md" "$REPO/constraints.txt" "$REPO/service" "$REPO/model_src" "$CTX/"
find "$CTX" -name __pycache__ -prune -exec rm -rf {} +
log "pip wheel (host) -> $CTX/wheels"
"$PYTHON" -m pip wheel -q -c "$CTX/constraints.txt" -w "$CTX/wheels" "$CTX[service,dask]" >"$WORK/wheel.log" 2>&1 \
    || { tail -20 "$WORK/wheel.log"; echo "FAILED: pip wheel"; exit 1; }

log "podman build $IMAGE (base $BASE)"
"${PODMAN[@]}" build "${ULIMITS[@]}" --network host -f "$REPO/docker/Dockerfile" \
    --build-arg BASE_IMAGE="$BASE" -t "$IMAGE" "$CTX" >"$WORK/build.log" 2>&1 \
    || { tail -30 "$WORK/build.log"; echo "FAILED: podman build (log: $WORK/build.log)"; exit 1; }

# ---- run it and post a real job -------------------------------------------------------------
PORT=$("$PYTHON" -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
NAME=fmuid-test-$$
cleanup() { "${PODMAN[@]}" rm -f "$NAME" >/dev/null 2>&1 || true; }
trap cleanup EXIT
log "podman run $IMAGE on 127.0.0.1:$PORT"
"${PODMAN[@]}" run -d --name "$NAME" "${ULIMITS[@]}" --network host \
    -e FMUID_API_TOKEN="$TOKEN" "$IMAGE" fmuid serve --host 127.0.0.1 --port "$PORT" >/dev/null
URL=http://127.0.0.1:$PORT
for _ in $(seq 60); do
    curl -sf "$URL/v1/health" >/dev/null && break
    sleep 1
done
curl -sf "$URL/v1/health" || { "${PODMAN[@]}" logs "$NAME" | tail -30; echo "FAILED: no health"; exit 1; }
echo
[ "$("${PODMAN[@]}" exec "$NAME" id -u)" != 0 ] || { echo "FAILED: service runs as root"; exit 1; }

"$PYTHON" - "$WORK/step.csv" <<'PY'
import sys
import numpy as np
from scipy.integrate import solve_ivp
m, k, b, force = 1.1, 4.4, 1.6, 40.0
t = np.arange(0.0, 10.0 + 1e-9, 0.2)
sol = solve_ivp(lambda _t, y: [y[1], (force - b * y[1] - k * y[0]) / m], (0, 10), [0, 0],
                t_eval=t, rtol=1e-11, atol=1e-12)
x = sol.y[0] + np.random.default_rng(3).normal(0.0, 0.05, t.size)
with open(sys.argv[1], "w") as f:
    f.write("time,f,x\n" + "".join(f"{ti:.6g},{force:g},{xi:.9g}\n" for ti, xi in zip(t, x)))
PY
SPEC='{"parameters": {"m": {"start": 2, "lower": 0.1, "upper": 10}, "k": {"start": 2, "lower": 0.1, "upper": 10}, "b": {"start": 1, "lower": 0.1, "upper": 10}}, "inputs": ["f"], "outputs": {"x": {"sigma": 0.05}}, "global_search": false}'
AUTH=(-H "Authorization: Bearer $TOKEN")
code=$(curl -s -o /dev/null -w '%{http_code}' "$URL/v1/jobs")
[ "$code" = 401 ] || { echo "FAILED: GET /v1/jobs without token gave $code, not 401"; exit 1; }
JOB=$(curl -sf "${AUTH[@]}" -F kind=fit -F model=msd -F "spec=$SPEC" -F "data=@$WORK/step.csv" \
    "$URL/v1/jobs" | "$PYTHON" -c 'import json,sys; print(json.load(sys.stdin)["id"])')
log "job $JOB posted"
status=queued
for _ in $(seq 300); do
    status=$(curl -sf "${AUTH[@]}" "$URL/v1/jobs/$JOB" | "$PYTHON" -c 'import json,sys; print(json.load(sys.stdin)["status"])')
    case $status in done|failed|cancelled) break;; esac
    sleep 1
done
curl -sf "${AUTH[@]}" "$URL/v1/jobs/$JOB"; echo
[ "$status" = done ] || { "${PODMAN[@]}" logs "$NAME" | tail -30; echo "FAILED: job $status"; exit 1; }
curl -sf "${AUTH[@]}" "$URL/v1/jobs/$JOB/result" | "$PYTHON" -c '
import json, sys
r = json.load(sys.stdin)
est = r.get("estimates") or {n: p["estimate"] for n, p in r["parameters"].items()}
truth = {"m": 1.1, "k": 4.4, "b": 1.6}
print("estimates:", {n: round(v, 4) for n, v in est.items()})
bad = {n: v for n, v in est.items() if abs(v - truth[n]) > 0.1 * truth[n]}
sys.exit(f"FAILED: estimates far from the truth: {bad}" if bad else 0)
'
echo "PASSED: image $IMAGE built, ran as non-root, answered a fit job with model=msd"
