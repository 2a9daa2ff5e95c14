#!/usr/bin/env bash
# Runs examples/python/anguilla_client.py against a live daemon (the built-in
# simulated robot) on a prefix of its own, then stops the daemon with SIGTERM.
# Exits with the client's status. Used by CI.
#   ANGUILLA_BIN  the daemon binary (default: target/release/anguilla if built,
#                 else target/debug/anguilla), relative to the repository root
set -euo pipefail
cd "$(dirname "$0")/../.."

if ! python3 -c 'import iceoryx2' 2>/dev/null; then
    echo "installing iceoryx2==0.10.0 (Python bindings) with pip"
    PIP_ROOT_USER_ACTION=ignore python3 -m pip install --quiet --disable-pip-version-check \
        iceoryx2==0.10.0
fi

bin=${ANGUILLA_BIN:-}
if [[ -z $bin ]]; then
    bin=target/debug/anguilla
    [[ -x target/release/anguilla ]] && bin=target/release/anguilla
fi
[[ -x $bin ]] || { echo "no daemon binary at $bin (build it, or set ANGUILLA_BIN)" >&2; exit 1; }

tmp=$(mktemp -d)
prefix="anguilla-py/example-$$-$RANDOM"
printf '[ipc]\nprefix = "%s"\n' "$prefix" >"$tmp/anguilla.toml"
daemon=""

stop_daemon() {
    local status=$?
    if [[ -n $daemon ]] && kill -0 "$daemon" 2>/dev/null; then
        kill -TERM "$daemon"
        for _ in $(seq 100); do kill -0 "$daemon" 2>/dev/null || break; sleep 0.1; done
        if kill -0 "$daemon" 2>/dev/null; then
            echo "daemon $daemon ignored SIGTERM for 10 s: killing it" >&2
            kill -KILL "$daemon"
            status=1
        fi
        wait "$daemon" 2>/dev/null || true
    fi
    if [[ $status -ne 0 && -s $tmp/daemon.log ]]; then
        echo "--- daemon log (last 20 lines)" >&2
        tail -n 20 "$tmp/daemon.log" >&2
    fi
    rm -rf "$tmp"
    exit "$status"
}
trap stop_daemon EXIT

"$bin" run --config "$tmp/anguilla.toml" --quiet >"$tmp/daemon.log" 2>&1 &
daemon=$!
echo "daemon: $bin, pid $daemon, prefix $prefix"

# Wait until the daemon serves its prefix (`ctl status` exits 2 until then).
for _ in $(seq 150); do
    "$bin" ctl --prefix "$prefix" status >/dev/null 2>&1 && break
    kill -0 "$daemon" 2>/dev/null || { echo "the daemon exited at start" >&2; exit 1; }
    sleep 0.2
done
"$bin" ctl --prefix "$prefix" status >/dev/null || { echo "no daemon after 30 s" >&2; exit 1; }

start=$SECONDS
status=0
timeout 120 python3 examples/python/anguilla_client.py --prefix "$prefix" || status=$?
echo "client: exit $status after $((SECONDS - start)) s"
exit "$status"
