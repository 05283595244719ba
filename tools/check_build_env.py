#!/usr/bin/env python3
"""Checks that the scripts which configure a build do it one way, tools/build_env.sh's (a test of the suite).

The demo once configured without the compiler launcher and the test command with it, so the test command after the
demo recompiled every object. Each script below must source tools/build_env.sh and configure only through it
(configure_build / build_preset), never with a `cmake --preset` or a launcher or ccache setting of its own; the demo
and the test command must build the same preset.

    python3 tools/check_build_env.py [REPO]
"""
import pathlib
import re
import sys

SCRIPTS = ["tools/demo.sh", "tools/test.sh", "tools/test_arm64.sh", "tools/fuzz.sh"]
OWN_SETTINGS = [
    (re.compile(r"^\s*[^#\n]*\bcmake\s+--preset\b", re.M), "configures with `cmake --preset` itself"),
    (re.compile(r"^\s*[^#\n]*COMPILER_LAUNCHER", re.M), "sets a compiler launcher itself"),
    (re.compile(r"^\s*[^#\n]*\bCCACHE_[A-Z]+=", re.M), "sets ccache's environment itself"),
]
SOURCES = re.compile(r"^\s*(source|\.)\s+tools/build_env\.sh\b", re.M)


def problems(repo):
    found = []
    for name in SCRIPTS:
        text = (repo / name).read_text()
        if not SOURCES.search(text):
            found.append(f"{name} does not source tools/build_env.sh")
        for pattern, what in OWN_SETTINGS:
            for m in pattern.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                found.append(f"{name}:{line} {what}: {m.group(0).strip()}")
    demo = (repo / "tools/demo.sh").read_text()
    test = (repo / "tools/test.sh").read_text()
    demo_presets = set(re.findall(r"^\s*build_preset\s+(\w+)", demo, re.M))
    test_default = re.search(r"^preset=(\w+)", test, re.M)
    if demo_presets != {"release"} or not test_default or test_default.group(1) != "release":
        found.append(f"tools/demo.sh builds {sorted(demo_presets)}, tools/test.sh's default preset is "
                     f"{test_default.group(1) if test_default else None}: both must build `release`")
    if not re.search(r'^\s*step_build\(\)\s*\{\s*build_preset\s+"\$preset";', test, re.M):
        found.append("tools/test.sh's step_build does not build through build_preset")
    return found


def main():
    repo = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[1])
    found = problems(repo)
    for p in found:
        print("check_build_env: " + p, file=sys.stderr)
    if found:
        return 1
    print(f"check_build_env: {len(SCRIPTS)} scripts configure through tools/build_env.sh")
    return 0


if __name__ == "__main__":
    sys.exit(main())
