#!/bin/sh
# Runs the vcan test binaries listed in LIST and prints one result line per
# binary plus a final summary line `vcan-vm: N passed, M failed`. The
# tests that need vcan or uinput are `#[ignore]`d under plain `cargo test`
# (counted there as ignored, with the reason): every binary here runs with
# --include-ignored.
#
# Used as-is by the VM's /init (busybox sh) and by `scripts/vcan-vm --native`
# (the host's sh), so keep it POSIX.
#
# LIST has one test binary per line: `NAME<TAB>PATH<TAB>DIR[<TAB>ARGS]`; the
# binary runs in DIR (its package's directory, as under `cargo test`), ARGS
# are extra libtest arguments (filters), whitespace-separated. Each binary runs with --test-threads=1
# and --nocapture (so skip messages reach the log and are counted),
# and ANGUILLA_VCAN set (default vcan0). N and M count individual tests (from
# libtest's `test result:` line); a binary that fails without one counts as
# one failure. The can-utils interop check counts as one test. Each binary
# is killed after VCAN_BINARY_TIMEOUT seconds (default 300).
#
# Usage: run-tests.sh LIST [WORKDIR]

list=$1
work=${2:-/tmp/vcan-vm}
mkdir -p "$work"
: "${ANGUILLA_VCAN:=vcan0}"
export ANGUILLA_VCAN
export RUST_BACKTRACE=${RUST_BACKTRACE:-1}
# Each binary gets this long, so one hung binary still leaves a summary.
binary_timeout=${VCAN_BINARY_TIMEOUT:-300}

passed=0
failed=0
ignored=0
skipped=0

result() { # NAME STATUS PASSED FAILED IGNORED SKIPS EXIT
    echo "vcan-vm: RESULT $1: $2 ($3 passed, $4 failed, $5 ignored, $6 skip messages, exit $7)"
}

# --- can-utils interoperability: cansend -> candump on the test interface.
interop() {
    name="can-utils: cansend -> candump on $ANGUILLA_VCAN"
    echo "vcan-vm: RUN $name"
    if ! command -v candump >/dev/null 2>&1 || ! command -v cansend >/dev/null 2>&1; then
        echo "vcan-vm: candump/cansend not found"
        failed=$((failed + 1))
        result "$name" FAILED 0 1 0 0 127
        return
    fi
    out=$work/candump.out
    rm -f "$out"
    # -n 1: exit after one frame; -T: give up after 5 s without traffic.
    candump -n 1 -T 5000 "$ANGUILLA_VCAN" >"$out" 2>&1 &
    pid=$!
    sleep 1 # let candump bind before sending
    cansend "$ANGUILLA_VCAN" 123#DEADBEEF
    send=$?
    wait "$pid"
    dump=$?
    cat "$out"
    if [ "$send" -eq 0 ] && [ "$dump" -eq 0 ] && grep -q '123 *\[4\] *DE AD BE EF' "$out"; then
        passed=$((passed + 1))
        result "$name" ok 1 0 0 0 0
    else
        failed=$((failed + 1))
        result "$name" FAILED 0 1 0 0 "$send/$dump"
    fi
}

run_binary() { # NAME PATH DIR [ARGS...]
    name=$1
    bin=$2
    dir=$3
    shift 3
    log=$work/$name.log
    echo "vcan-vm: RUN $name ($bin --include-ignored --test-threads=1 --nocapture $*)"
    # Stream the output and keep a copy to read the counts from; the exit
    # status goes through a file because a pipeline reports tee's.
    {
        (cd "$dir" && exec timeout -s KILL "$binary_timeout" "$bin" --include-ignored --test-threads=1 --nocapture "$@") 2>&1
        echo $? >"$work/$name.rc"
    } | tee "$log"
    rc=$(cat "$work/$name.rc" 2>/dev/null || echo 255)
    if [ "$rc" -eq 137 ] || [ "$rc" -eq 124 ]; then
        echo "vcan-vm: $name killed after $binary_timeout s (hung?)"
    fi
    line=$(grep '^test result:' "$log" | tail -n 1)
    skips=$(grep -c 'skipping' "$log")
    if [ -n "$line" ]; then
        p=$(echo "$line" | sed -n 's/.* \([0-9][0-9]*\) passed.*/\1/p')
        f=$(echo "$line" | sed -n 's/.* \([0-9][0-9]*\) failed.*/\1/p')
        i=$(echo "$line" | sed -n 's/.* \([0-9][0-9]*\) ignored.*/\1/p')
    else
        p=0 f=0 i=0
    fi
    : "${p:=0}" "${f:=0}" "${i:=0}"
    if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then
        f=1 # crashed, timed out or failed before libtest's summary
    fi
    passed=$((passed + p))
    failed=$((failed + f))
    ignored=$((ignored + i))
    skipped=$((skipped + skips))
    if [ "$rc" -eq 0 ] && [ "$f" -eq 0 ]; then
        result "$name" ok "$p" "$f" "$i" "$skips" "$rc"
    else
        result "$name" FAILED "$p" "$f" "$i" "$skips" "$rc"
    fi
}

echo "vcan-vm: interface $ANGUILLA_VCAN; kernel $(uname -r)"
for i in /sys/class/net/vcan*; do
    [ -e "$i" ] && echo "vcan-vm: ${i##*/} mtu $(cat "$i/mtu") $(cat "$i/operstate")"
done
if [ -c /dev/uinput ]; then
    echo "vcan-vm: /dev/uinput present"
else
    echo "vcan-vm: no /dev/uinput"
fi

interop

tab=$(printf '\t')
while IFS="$tab" read -r name bin dir args; do
    case $name in '' | '#'*) continue ;; esac
    # shellcheck disable=SC2086 # ARGS are whitespace-separated on purpose
    run_binary "$name" "$bin" "$dir" $args
done <"$list"

echo "vcan-vm: $ignored ignored, $skipped skip messages"
echo "vcan-vm: $passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
