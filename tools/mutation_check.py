#!/usr/bin/env python3
"""Mutation check: plants small bugs one at a time in a scratch copy of the checkout and reports which tests of the
bug's own layer kill each (fail on it). A test suite whose layer tests pass on a planted bug has a blind spot there.

    python3 tools/mutation_check.py [--mutations tools/mutations.json] [--only ID ...] [--list] [-o report.json]

Each mutation (tools/mutations.json) names a file, the exact text to replace (it must occur once), its replacement,
the layer's tests to run and the tests expected to kill it:

    {"id": "map-block-past-upper-edge", "layer": "map", "file": "src/map/tsdf_map.cpp",
     "find": "(c.array() >= dims_blocks_.array()).any()", "replace": "(c.array() > dims_blocks_.array()).any()",
     "gtest": ["map"], "expect": ["TsdfMap.TheBlockJustPastTheBoxOnEachAxisIsOutside"]}

"gtest" lists test folders (tests/<folder>/test_*.cpp): their suites run from the suite's one binary; "pytest" lists
files under python/tests (the module's tests). The working tree is never touched: the checkout (tracked files and
untracked ones git does not ignore) is copied to a scratch folder (TSDF_MCL_MUTATION_DIR, default
/tmp/tsdf-mcl-mutation/<checkout name>), configured once as tools/build_env.sh configures (ccache: only the planted
file and what includes it compile anew) and reused by later runs. Before the mutants, the selected tests run once on
the unmutated copy: a test that fails there kills nothing. The report (JSON, on stdout or -o) lists per mutant the
tests that failed, whether every expected killer did, and the times; a table goes to stderr. Exit status 1 if an
expected killer survived a mutant (or a mutation no longer applies), else 0.
"""
import argparse
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
TEST_MACRO = re.compile(r"^\s*TEST(?:_F|_P)?\(\s*(\w+)\s*,", re.M)


def log(text):
    print(f"mutation_check: {text}", file=sys.stderr, flush=True)


def run(command, cwd, timeout=None, env=None):
    return subprocess.run(command, cwd=cwd, env=env, timeout=timeout, capture_output=True, text=True)


def sync_scratch(root, scratch):
    """The checkout's files into scratch/src; a file whose bytes are unchanged keeps its time (ninja rebuilds
    nothing for it), a file gone from the checkout goes from the copy (its build folder stays)."""
    listed = run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], root).stdout.split("\0")
    names = {n for n in listed if n and (root / n).is_file()}
    src = scratch / "src"
    for name in sorted(names):
        source, target = root / name, src / name
        if not target.is_file() or target.read_bytes() != source.read_bytes():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    for path in src.rglob("*"):
        relative = path.relative_to(src).as_posix()
        if path.is_file() and not relative.startswith("build/") and relative not in names:
            path.unlink()
    return src


def build(src, targets, timeout):
    """Configures once (tools/build_env.sh) and builds the targets; (ok, seconds, log tail)."""
    script = ("source tools/build_env.sh && configure_build release && "
              f"cmake --build --preset release -j \"$(nproc)\" --target {' '.join(targets)}")
    t0 = time.monotonic()
    try:
        result = run(["bash", "-c", script], src, timeout=timeout)
    except subprocess.TimeoutExpired:
        return False, time.monotonic() - t0, "build timed out"
    return result.returncode == 0, time.monotonic() - t0, (result.stdout + result.stderr)[-2000:]


def gtest_filter(src, folders):
    suites = set()
    for folder in folders:
        for path in sorted((src / "tests" / folder).glob("test_*.cpp")):
            suites.update(TEST_MACRO.findall(path.read_text()))
    if not suites:
        sys.exit(f"mutation_check: no tests in tests/{{{','.join(folders)}}}")
    return ":".join(f"{s}.*:*/{s}.*" for s in sorted(suites))


def run_gtest(src, folders, timeout):
    """The folders' suites; the names of the tests that failed (a crash: the test that was running)."""
    binary = src / "build/release/tests/tsdf_mcl_tests"
    report = src / "build/release/mutation_gtest.json"
    report.unlink(missing_ok=True)
    env = dict(os.environ, TSDF_MCL_VALIDATION="1", OMP_WAIT_POLICY="passive", LP_NUM_THREADS="2")
    try:
        result = run([str(binary), f"--gtest_filter={gtest_filter(src, folders)}", f"--gtest_output=json:{report}"],
                     src / "build/release/tests", timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return ["(timed out)"]
    if report.exists():
        data = json.loads(report.read_text())
        failed = [f"{suite['name']}.{test['name']}" for suite in data.get("testsuites", [])
                  for test in suite.get("testsuite", []) if test.get("failures")]
        if failed or result.returncode == 0:
            return failed
    started = re.findall(r"^\[ RUN      \] (\S+)", result.stdout, re.M)
    return [f"(crashed in {started[-1] if started else 'start-up'}, exit {result.returncode})"]


def run_pytest(src, files, timeout):
    build_dir = src / "build/release"
    env = dict(os.environ, PYTHONPATH=str(build_dir / "python"), PYTHONDONTWRITEBYTECODE="1",
               TSDF_MCL_CLI=str(build_dir / "tools/tsdf-mcl"), OMP_WAIT_POLICY="passive")
    paths = [str(src / "python/tests" / f) for f in files]
    try:
        result = run(["/usr/bin/python3", "-m", "pytest", "-q", "-rf", "-p", "no:cacheprovider", *paths], src,
                     timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return ["(timed out)"]
    failed = re.findall(r"^FAILED (\S+)", result.stdout, re.M)
    if result.returncode != 0 and not failed:
        return [f"(pytest exit {result.returncode}: {result.stdout.strip().splitlines()[-1:]})"]
    return [re.sub(r"^.*python/tests/", "", f) for f in failed]


def selection(mutant):
    return ("gtest", tuple(mutant["gtest"])) if "gtest" in mutant else ("pytest", tuple(mutant["pytest"]))


def run_selection(src, kind, names, timeout):
    return run_gtest(src, list(names), timeout) if kind == "gtest" else run_pytest(src, list(names), timeout)


def targets_of(kind):
    return ["tsdf_mcl_tests", "tsdf-mcl"] if kind == "gtest" else ["tsdf_mcl_python", "tsdf-mcl"]


def check_mutant(src, mutant, baseline, args):
    path = src / mutant["file"]
    original = path.read_text()
    entry = {key: mutant[key] for key in ("id", "layer", "file")}
    entry["expected"] = mutant.get("expect", [])
    if original.count(mutant["find"]) != 1:
        entry.update(status="does not apply", detail=f"the text occurs {original.count(mutant['find'])} times")
        return entry
    kind, names = selection(mutant)
    path.write_text(original.replace(mutant["find"], mutant["replace"]))
    try:
        ok, seconds, tail = build(src, targets_of(kind), args.build_timeout)
        entry["build_s"] = round(seconds, 1)
        if not ok:
            entry.update(status="build failed", detail=tail.strip().splitlines()[-3:])
            return entry
        t0 = time.monotonic()
        failed = run_selection(src, kind, names, args.test_timeout)
        entry["test_s"] = round(time.monotonic() - t0, 1)
    finally:
        path.write_text(original)
    entry["killed_by"] = [t for t in failed if t not in baseline[(kind, names)]]
    entry["killed"] = bool(entry["killed_by"])
    entry["missed"] = [t for t in entry["expected"] if t not in entry["killed_by"]]
    entry["status"] = "killed" if entry["killed"] and not entry["missed"] else "survived" if not entry["killed"] \
        else "killed, not by every expected test"
    return entry


def table(entries):
    rows = [("mutant", "layer", "status", "killed by")]
    for e in entries:
        killers = e.get("killed_by") or []
        shown = ", ".join(killers[:3]) + (f" (+{len(killers) - 3})" if len(killers) > 3 else "")
        rows.append((e["id"], e["layer"], e["status"], shown or "-"))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    return "\n".join("  ".join(r[i].ljust(widths[i]) for i in range(3)) + "  " + r[3] for r in rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mutations", default=str(ROOT / "tools/mutations.json"))
    parser.add_argument("--only", nargs="*", help="mutant ids to run (default: all)")
    parser.add_argument("--list", action="store_true", help="list the mutants and exit")
    parser.add_argument("-o", "--output", help="write the JSON report here instead of stdout")
    parser.add_argument("--build-timeout", type=int, default=3600)
    parser.add_argument("--test-timeout", type=int, default=1800)
    args = parser.parse_args()
    mutants = json.loads(pathlib.Path(args.mutations).read_text())["mutants"]
    if args.only:
        unknown = set(args.only) - {m["id"] for m in mutants}
        if unknown:
            sys.exit(f"mutation_check: unknown mutant ids {sorted(unknown)}")
        mutants = [m for m in mutants if m["id"] in args.only]
    if args.list:
        for m in mutants:
            print(f"{m['id']:40} {m['layer']:10} {m['file']}")
        return 0
    scratch = pathlib.Path(os.environ.get("TSDF_MCL_MUTATION_DIR", f"/tmp/tsdf-mcl-mutation/{ROOT.name}"))
    src = sync_scratch(ROOT, scratch)
    log(f"scratch copy {src}")
    baseline = {}
    for kind in sorted({selection(m)[0] for m in mutants}):
        ok, seconds, tail = build(src, targets_of(kind), args.build_timeout)
        log(f"unmutated build ({kind}) in {seconds:.0f} s")
        if not ok:
            sys.exit(f"mutation_check: the unmutated copy does not build:\n{tail}")
    for key in sorted({selection(m) for m in mutants}):
        baseline[key] = run_selection(src, *key, args.test_timeout)
        log(f"unmutated {key[0]} {','.join(key[1])}: {len(baseline[key])} failing {baseline[key]}")
    entries = []
    for m in mutants:
        log(f"{m['id']}: planting in {m['file']}")
        entries.append(check_mutant(src, m, baseline, args))
        log(f"{m['id']}: {entries[-1]['status']} {entries[-1].get('killed_by', '')}")
    # The scratch copy is left as the checkout is: the next run rebuilds only what changed since.
    build(src, sorted({t for m in mutants for t in targets_of(selection(m)[0])}), args.build_timeout)
    report = {"checkout": str(ROOT), "scratch": str(src), "baseline_failures": {
        f"{k[0]}:{','.join(k[1])}": v for k, v in baseline.items()}, "mutants": entries}
    text = json.dumps(report, indent=2)
    if args.output:
        pathlib.Path(args.output).write_text(text + "\n")
    else:
        print(text)
    print(table(entries), file=sys.stderr)
    return 1 if any(e["status"] != "killed" for e in entries) else 0


if __name__ == "__main__":
    sys.exit(main())
