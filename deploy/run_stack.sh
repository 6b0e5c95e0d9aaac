#!/usr/bin/env bash
# run_stack.sh: run deploy/compose.yaml for real and check that it answers on its workers.
#
# Builds the image, starts the scheduler, the two workers and the service with a compose
# tool, waits for the service to be ready and both workers to join, sends one
# initiation.evaluate through the service's published loopback port, and checks that
#   - it is answered 200;
#   - the workers ran every chunk of it (each worker's count of tasks executed, asked of
#     the scheduler before and after: the service process runs none);
#   - the answer is, bit for bit, the one the same image computes in one process
#     (plotgate call, no cluster);
#   - the exchange is in the service's recording (plotgate inspect).
# Then (unless NO_FAULTS=1) the faults: a long evaluate given up by its client after 5 s
# has its tasks cancelled on the scheduler; the scheduler container killed mid-request
# answers it 503 with Retry-After; started again, the workers rejoin it and the next
# evaluate runs on them, with the same answer; the 499 and the 503 are recorded.
# The stack (containers, their volumes, its network) and the image it built are removed
# on exit, whatever happens (trap), and every wait is bounded.
#
# Usage: deploy/run_stack.sh        (from anywhere; the repository is this file's parent)
# Environment:
#   ENGINE              container engine (podman; docker with COMPOSE="docker compose")
#   COMPOSE             compose tool (podman-compose on PATH, else the repository's .venv)
#   PLOTGATE_IMAGE      the image built and run (localhost/plotgate:stack)
#   PLOTGATE_HOST_PORT  the service's loopback port (a free one)
#   STACK_WAIT_S        longest wait for each step, s (240)
#   NO_BUILD=1          run PLOTGATE_IMAGE as it is, and leave it at the end
#   KEEP_IMAGE=1        leave the image built at the end
#   NO_FAULTS=1         stop after the first evaluate
# Exit: 0 the stack answered on its workers; 1 it did not (build, start, answer; each
# container's last log lines are printed); 2 a tool is missing.
set -uo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
FILE=$ROOT/deploy/compose.yaml
ENGINE=${ENGINE:-podman}
WAIT_S=${STACK_WAIT_S:-240}
PROJECT=plotgate-stack-$$
BODY='{"runs": 200, "seed": 1, "scenario": {"clutter": 50}, "config": {"mode": "polar", "v_max": 30}}'
export PLOTGATE_IMAGE=${PLOTGATE_IMAGE:-localhost/plotgate:stack}

say() { printf '[run_stack %s] %s\n' "$(date -u +%H:%M:%S)" "$*" >&2; }
fail() { say "FAIL: $*"; exit 1; }

command -v "$ENGINE" > /dev/null || { say "no $ENGINE on PATH"; exit 2; }
if [ -z "${COMPOSE:-}" ]; then
  if command -v podman-compose > /dev/null; then COMPOSE=podman-compose
  elif [ -x "$ROOT/.venv/bin/podman-compose" ]; then COMPOSE=$ROOT/.venv/bin/podman-compose
  else say 'no compose tool: pip install "plotgate[deploy]" (podman-compose), or set COMPOSE'; exit 2
  fi
fi
read -r -a COMPOSE_CMD <<< "$COMPOSE"
if [ -z "${PLOTGATE_HOST_PORT:-}" ]; then
  PLOTGATE_HOST_PORT=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])') \
    || { say "python3 is needed to pick a free port (or set PLOTGATE_HOST_PORT)"; exit 2; }
fi
export PLOTGATE_HOST_PORT
URL=http://127.0.0.1:$PLOTGATE_HOST_PORT
WORK=$(mktemp -d)

compose() { timeout "$WAIT_S" "${COMPOSE_CMD[@]}" -p "$PROJECT" -f "$FILE" "$@"; }
containers() { "$ENGINE" ps -a -q --filter "label=com.docker.compose.project=$PROJECT" "$@"; }
dangling() { "$ENGINE" images -q --no-trunc --filter dangling=true; }
one() { containers --filter "label=com.docker.compose.service=$1" | head -1; }

logs() {
  local id
  for id in $(containers); do
    echo "----- $("$ENGINE" inspect --format '{{.Name}}' "$id") (last 40 lines)"
    "$ENGINE" logs "$id" 2>&1 | tail -40
  done
}

teardown() {
  local status=$? ids anonymous='' volume image
  trap - EXIT INT TERM
  [ "$status" = 0 ] || logs >&2
  say "tearing down $PROJECT"
  # the anonymous /data volumes the image's VOLUME gives the scheduler and the workers,
  # which compose's down -v leaves (it removes the named ones)
  ids=$(containers)
  [ -z "$ids" ] || anonymous=$("$ENGINE" inspect --format \
    '{{range .Mounts}}{{if and (eq .Type "volume") (eq (len .Name) 64)}}{{.Name}} {{end}}{{end}}' $ids)
  compose down -v -t 30 > "$WORK/down.log" 2>&1
  [ -z "$(containers)" ] || say "WARNING: containers of $PROJECT left: $(containers | tr '\n' ' ')"
  for volume in ${anonymous:-}; do "$ENGINE" volume rm "$volume" > /dev/null 2>&1; done
  if [ -z "${NO_BUILD:-}" ] && [ -z "${KEEP_IMAGE:-}" ]; then
    "$ENGINE" rmi "$PLOTGATE_IMAGE" > /dev/null 2>&1 && say "removed the image $PLOTGATE_IMAGE"
    # what this build left untagged: its builder stage; an image another build still
    # uses is refused by rmi (no -f)
    for image in $(dangling | grep -vxF -f "$WORK/dangling"); do
      "$ENGINE" rmi "$image" > /dev/null 2>&1
    done
  fi
  rm -rf "$WORK"
  exit "$status"
}
trap teardown EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

if [ -z "${NO_BUILD:-}" ]; then
  say "building $PLOTGATE_IMAGE from $ROOT"
  dangling > "$WORK/dangling"
  # podman's default format, OCI, has no HEALTHCHECK: the image's own would be dropped
  format=(); [ "$(basename "$ENGINE")" = podman ] && format=(--format docker)
  timeout $((WAIT_S * 5)) "$ENGINE" build "${format[@]}" -t "$PLOTGATE_IMAGE" "$ROOT" > "$WORK/build.log" 2>&1 \
    || { tail -30 "$WORK/build.log" >&2; fail "the image did not build"; }
fi

say "starting $PROJECT (${COMPOSE_CMD[*]}): scheduler, 2 workers, service on $URL"
compose up -d > "$WORK/up.log" 2>&1 || { tail -30 "$WORK/up.log" >&2; fail "compose up failed"; }

deadline=$((SECONDS + WAIT_S))
until [ "$(curl -s -o /dev/null -w '%{http_code}' --max-time 3 "$URL/readyz")" = 200 ]; do
  [ $SECONDS -lt $deadline ] || fail "the service was not ready within ${WAIT_S} s"
  sleep 1
done
say "the service is ready"

SERVICE=$(one plotgate)
[ -n "$SERVICE" ] || fail "no container of the service plotgate"
# Each worker's count of tasks executed, asked of the scheduler from the service's
# container, after both workers have joined; and the chunks the body makes.
executed() {
  "$ENGINE" exec -i "$SERVICE" timeout "$WAIT_S" python - "$WAIT_S" <<'EOF'
import sys
from distributed import Client
from plotgate.core.initiation.evaluate import CHUNK_RUNS
wait = float(sys.argv[1])
with Client("tcp://scheduler:8786", timeout=wait) as client:
    client.wait_for_workers(2, timeout=wait)
    counts = client.run(lambda dask_worker: dask_worker.state.executed_count)
for worker, count in sorted(counts.items()):
    print(worker, count)
print("chunk_runs", CHUNK_RUNS)
EOF
}
executed > "$WORK/before" || fail "the two workers did not join the scheduler within ${WAIT_S} s"
say "2 workers joined: $(grep -v chunk_runs "$WORK/before" | cut -d' ' -f1 | paste -sd' ' -)"

say "POST $URL/v1/initiation/evaluate $BODY"
code=$(curl -s -o "$WORK/answer.json" -w '%{http_code}' --max-time "$WAIT_S" \
  -H 'content-type: application/json' -d "$BODY" "$URL/v1/initiation/evaluate")
say "answered $code: $(cat "$WORK/answer.json")"
[ "$code" = 200 ] || fail "the evaluate was answered $code"

executed > "$WORK/after" || fail "the scheduler did not answer after the evaluate"
runs=$(python3 -c 'import json, sys; print(json.loads(sys.argv[1])["runs"])' "$BODY")
chunk_runs=$(awk '$1 == "chunk_runs" {print $2}' "$WORK/after")
chunks=$(( (runs + chunk_runs - 1) / chunk_runs ))
ran=0 busy=0
while read -r worker after; do
  [ "$worker" = chunk_runs ] && continue
  before=$(awk -v w="$worker" '$1 == w {print $2}' "$WORK/before")
  n=$((after - ${before:-0}))
  say "worker $worker ran $n chunks"
  ran=$((ran + n)); [ "$n" -gt 0 ] && busy=$((busy + 1))
done < "$WORK/after"
[ "$ran" = "$chunks" ] || fail "the workers ran $ran chunks, not the evaluate's $chunks"
say "the workers ran all $chunks chunks ($busy of 2 workers took part)"

printf '%s' "$BODY" | "$ENGINE" exec -i "$SERVICE" sh -c \
  'cat > /tmp/evaluate.json && timeout '"$WAIT_S"' plotgate call initiation.evaluate /tmp/evaluate.json' \
  > "$WORK/alone.json" || fail "plotgate call in-process failed in the image"
python3 -c 'import json, sys; sys.exit(json.load(open(sys.argv[1])) != json.load(open(sys.argv[2])))' \
  "$WORK/answer.json" "$WORK/alone.json" || fail "the stack's answer differs from the in-process one"
say "the answer is the in-process one, bit for bit (plotgate call in the same image)"

"$ENGINE" exec "$SERVICE" plotgate inspect /data > "$WORK/inspect.txt" 2>&1 || fail "plotgate inspect /data failed"
sed 's/^/    /' "$WORK/inspect.txt" >&2
grep -Eq '^initiation\.evaluate +1 +1 ' "$WORK/inspect.txt" || fail "the exchange is not in the recording"
[ -n "${NO_FAULTS:-}" ] && { say "PASS: the stack answered the evaluate on its workers, recorded"; exit 0; }

# The faults: a client that goes away, then the scheduler killed mid-request and started
# again. LONG has 80 chunks: minutes on two workers, far past every wait below.
LONG='{"runs": 2000, "seed": 1, "scenario": {"clutter": 250}, "config": {"mode": "polar", "v_max": 30}}'
post_long() {  # $1: curl's --max-time; prints the status and the seconds it took
  curl -s -o "$WORK/long.json" -D "$WORK/long.headers" -w '%{http_code} %{time_total}' \
    --max-time "$1" -H 'content-type: application/json' -d "$LONG" "$URL/v1/initiation/evaluate"
}
scheduler_tasks() {
  "$ENGINE" exec -i "$SERVICE" timeout 60 python - <<'PY'
from distributed import Client
with Client("tcp://scheduler:8786", timeout=30) as client:
    print(client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)))
PY
}

say "a client that goes away: an evaluate of 80 chunks, given up after 5 s"
post_long 5 > /dev/null
deadline=$((SECONDS + 30))
until [ "$(scheduler_tasks)" = 0 ]; do
  [ $SECONDS -lt $deadline ] || fail "its tasks were still on the scheduler 30 s after the client left"
  sleep 1
done
say "its tasks left the scheduler (cancelled) within $((30 - deadline + SECONDS)) s"

say "the scheduler killed mid-request: an evaluate of 80 chunks, the scheduler killed 8 s in"
SCHEDULER=$(one scheduler)
post_long "$WAIT_S" > "$WORK/killed" &
sleep 8
"$ENGINE" kill "$SCHEDULER" > /dev/null || fail "could not kill the scheduler"
wait
read -r code took < "$WORK/killed"
retry=$(awk -F': ' 'tolower($1) == "retry-after" {print $2}' "$WORK/long.headers" | tr -d '\r')
say "answered $code with Retry-After: ${retry:-none} after $took s: $(head -c 160 "$WORK/long.json")"
[ "$code" = 503 ] && [ -n "$retry" ] || fail "the request was not answered 503 with Retry-After"

say "the scheduler started again: the workers rejoin it (restart: unless-stopped)"
"$ENGINE" start "$SCHEDULER" > /dev/null || fail "could not start the scheduler again"
executed > "$WORK/before" || fail "the two workers did not join the restarted scheduler within ${WAIT_S} s"
code=$(curl -s -o "$WORK/again.json" -w '%{http_code}' --max-time "$WAIT_S" \
  -H 'content-type: application/json' -d "$BODY" "$URL/v1/initiation/evaluate")
executed > "$WORK/after" || fail "the restarted scheduler did not answer"
ran=$(join <(sort "$WORK/before") <(sort "$WORK/after") | awk '$1 != "chunk_runs" {n += $3 - $2} END {print n + 0}')
[ "$code" = 200 ] && [ "$ran" = "$chunks" ] || fail "answered $code, $ran chunks on the workers"
python3 -c 'import json, sys; sys.exit(json.load(open(sys.argv[1])) != json.load(open(sys.argv[2])))' \
  "$WORK/again.json" "$WORK/answer.json" || fail "the answer after the restart differs"
say "the next evaluate answered 200 on the restarted scheduler: all $chunks chunks on the workers, the same answer"

"$ENGINE" exec "$SERVICE" plotgate inspect /data > "$WORK/inspect.txt" 2>&1 || fail "plotgate inspect /data failed"
sed 's/^/    /' "$WORK/inspect.txt" >&2
grep -q 'status 499: 1' "$WORK/inspect.txt" && grep -q 'status 503: 1' "$WORK/inspect.txt" \
  || fail "the 499 and the 503 are not both in the recording"
say "PASS: answered on its workers and recorded; a request given up cancelled; 503 without its scheduler, which is used again once back"
