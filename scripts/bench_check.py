#!/usr/bin/env python3
"""Benchmarks that catch drift: runs the daemon benchmark and the model's
real-time factor briefly, prints each ratio figure beside its baseline
(.ci/bench-baseline.json) and fails when one is more than `factor` times
worse. Ratios, not times: each compares two things measured in the same run
(a latency against the control period, against raw iceoryx2, the loop's
jitter against cyclictest's), except the model's real-time factor, which
is the machine's speed and is given room accordingly (see the baseline).

Each benchmark runs `--runs` times (default 2) and the best figure of the
runs is compared: a shared machine makes figures worse, never better, so
the best run is the one that says what the code does.

    scripts/bench-check            # build, run, compare (exit 1 on a regression)
    scripts/bench-check --update   # write the figures of this run as the new baseline

Updating the baseline is a commit with its reason.
"""
import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BASELINE = ROOT / ".ci" / "bench-baseline.json"


def run_json_lines(cmd, env=None):
    out = subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True, text=True)
    lines = []
    for line in out.stdout.splitlines():
        line = line.strip()
        if line.startswith("{"):
            try:
                lines.append(json.loads(line))
            except json.JSONDecodeError as e:
                sys.exit(f"bench-check: {cmd[0]} printed a line that is not JSON ({e}): {line}")
    return lines


def build(all_exe=False):
    """Builds the daemon's benchmarks (its guidance benchmark too, which
    scripts/check-guidance runs) and the model's example in one cargo
    invocation (one feature resolution, so the model and nalgebra are
    compiled once) and returns their executables. The release profile, not
    `cargo bench`'s: the same code (opt-level 3, 4 codegen units; the bench
    profile differs only in carrying no debug information), and in CI the
    crates it shares with scripts/build-deb's release build (bindgen, syn,
    serde, zstd's C, 143 of its 241 units) are compiled once, not twice."""
    out = subprocess.run(
        ["cargo", "build", "--release", "--message-format=json-render-diagnostics",
         "-p", "anguilla-daemon", "--bench", "daemon", "--bench", "guidance",
         "-p", "anguilla-model", "--example", "realtime"],
        cwd=ROOT, check=True, stdout=subprocess.PIPE, text=True).stdout
    exe = {}
    for line in out.splitlines():
        try:
            m = json.loads(line)
        except json.JSONDecodeError:
            continue
        if m.get("reason") == "compiler-artifact" and m.get("executable"):
            exe[m["target"]["name"]] = m["executable"]
    missing = {"daemon", "guidance", "realtime"} - exe.keys()
    if missing:
        sys.exit(f"bench-check: cargo built no executable for {sorted(missing)}")
    if all_exe:
        return exe
    return exe["daemon"], exe["realtime"]


def figures_of(lines):
    """The ratio figures of one run, by name: (value, 'lower' or 'higher' is better)."""
    f = {}
    for b in lines:
        kind, setup = b.get("bench"), b.get("setup")
        if kind == "state_latency":
            f["state.p50_ratio_sched_other"] = (b["other_p50_ratio"], "lower")
            f["state.p50_ratio_sched_fifo"] = (b["fifo1_p50_ratio"], "lower")
        elif kind == "loop_jitter":
            f[f"loop.{setup}.p99_ratio_to_cyclictest"] = (b["p99_ratio"], "lower")
        elif kind == "command_latency":
            f[f"command.{setup}.p50_periods"] = (b["p50_periods"], "lower")
            f[f"command.{setup}.p99_periods"] = (b["p99_periods"], "lower")
        elif kind == "model_realtime":
            f["model.f1_52_intervals.realtime_factor"] = (b["realtime_factor"], "higher")
    return f


def measure(runs, daemon, realtime):
    env = dict(os.environ)
    env.setdefault("ANGUILLA_BENCH_SECONDS", "3")
    env.setdefault("ANGUILLA_BENCH_COMMANDS", "100")
    best, worst = {}, {}
    for i in range(runs):
        # `--bench`, as `cargo bench` passes it: the full-length run.
        lines = run_json_lines([daemon, "--bench"], env)
        lines += run_json_lines([realtime, "300"])
        for line in lines:
            print(f"run {i + 1}: {json.dumps(line)}")
        for name, (v, better) in figures_of(lines).items():
            if v != v:  # NaN: the figure could not be measured (no cyclictest)
                continue
            old = best.get(name)
            if old is None or (v < old[0] if better == "lower" else v > old[0]):
                best[name] = (v, better)
            old = worst.get(name)
            if old is None or (v > old[0] if better == "lower" else v < old[0]):
                worst[name] = (v, better)
    return best, worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--update", action="store_true", help="write this run's figures as the baseline")
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--build-only", action="store_true",
                    help="build the benchmarks and stop (CI builds them while its tests run)")
    args = ap.parse_args()
    daemon, realtime = build()
    if args.build_only:
        return 0
    best, worst = measure(args.runs, daemon, realtime)
    if args.update:
        # The baseline takes the worse figure of the runs, the check the
        # better one: a noisy run can neither set a bar too high nor fail.
        doc = {
            "about": "Ratio figures of scripts/bench-check: each the worse of the runs that wrote "
                     "it (CI compares the better of its own runs). A figure more than `factor` "
                     "times worse than here fails CI. Update with scripts/bench-check --update, "
                     "in a commit that says why; a figure set by hand says so in its `source`.",
            "factor": 2.0,
            "figures": {k: {"value": round(v, 3), "better": b} for k, (v, b) in sorted(worst.items())},
        }
        BASELINE.write_text(json.dumps(doc, indent=2) + "\n")
        print(f"bench-check: baseline written to {BASELINE.relative_to(ROOT)}")
        return 0
    try:
        base = json.loads(BASELINE.read_text())
        factor = float(base["factor"])
        figures = base["figures"]
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"bench-check: cannot read the baseline {BASELINE}: {e} "
                 "(expected JSON with 'factor' and 'figures'; write one with --update)")
    failed = []
    print(f"{'figure':<52} {'baseline':>10} {'now':>10} {'worse by':>9}")
    for name, ref in sorted(figures.items()):
        b, better = float(ref["value"]), ref["better"]
        if name not in best:
            print(f"{name:<52} {b:>10.3f} {'—':>10}   not measured in this run")
            if not name.startswith("loop."):  # cyclictest may be missing; the rest may not
                failed.append(f"{name}: not measured")
            continue
        v = best[name][0]
        worse = (v / b if b > 0 else float("inf")) if better == "lower" else (b / v if v > 0 else float("inf"))
        mark = "  REGRESSION" if worse > factor else ""
        print(f"{name:<52} {b:>10.3f} {v:>10.3f} {worse:>8.2f}×{mark}")
        if worse > factor:
            failed.append(f"{name}: {v:.3f} against {b:.3f} ({worse:.2f}× worse, limit {factor}×)")
    for name in sorted(set(best) - set(figures)):
        print(f"{name:<52} {'(none)':>10} {best[name][0]:>10.3f}   new: not in the baseline")
    if failed:
        print("bench-check: FAILED, more than %s× worse than the baseline:" % factor)
        for f in failed:
            print(f"  {f}")
        return 1
    print(f"bench-check: every figure within {factor}× of the baseline")
    return 0


if __name__ == "__main__":
    sys.exit(main())
