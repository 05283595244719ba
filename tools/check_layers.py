#!/usr/bin/env python3
"""Checks the library's layering (docs/architecture.md) in every source file, and that the build and the docs say
the same.

The allowed edges are the table LINKS below: a layer may include its own headers and those of the layers it links,
directly or through them. The check fails on
- an include of tsdf_mcl/<layer>/... from a layer that does not link <layer> (an include against the grain),
- an unqualified tsdf_mcl/X.hpp include, or a reach into src/ from outside the layer (tests, tools, bench, fuzz,
  ros and python use public headers and their own support folders),
- a tsdf_mcl_layer(...) call in src/CMakeLists.txt whose tsdf_mcl:: links differ from LINKS,
- a row of docs/architecture.md's layer table whose "links" column differs from LINKS.
Usage: python3 tools/check_layers.py [REPO_ROOT]. Exit 0 when clean, 1 with one line per finding.
"""
import pathlib
import re
import sys

# Direct links of each layer (PUBLIC or PRIVATE in src/CMakeLists.txt), from the bottom up.
LINKS = {
    "core": [],
    "io": ["core"],
    "map": ["core"],
    "mapping": ["map", "io"],
    "sensor": ["map"],
    "cpu": ["sensor"],
    "gpu": ["sensor"],
    "backends": ["sensor", "cpu", "gpu"],
    "filter": ["sensor"],
    "localizer": ["filter", "io", "backends"],
    "eval": ["io"],
    "sim": ["io"],
    "render": ["map", "io"],
}
# Folders outside the library: their files may include any public header, but nothing under src/.
FRONTENDS = ["tools", "tests", "bench", "fuzz", "ros", "python", "examples"]
SOURCE_SUFFIXES = {".cpp", ".hpp", ".h", ".c", ".cc"}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^">]+)[">]', re.MULTILINE)


def closure(layer):
    seen, todo = {layer}, [layer]
    while todo:
        for dep in LINKS[todo.pop()]:
            if dep not in seen:
                seen.add(dep)
                todo.append(dep)
    return seen


def source_files(folder):
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix in SOURCE_SUFFIXES)


def check_file(root, path, layer, findings):
    """layer: the library layer owning path, or None for a frontend (tests, tools, ...)."""
    rel = path.relative_to(root)
    src_root = (root / "src").resolve()
    allowed = closure(layer) if layer else set(LINKS)
    text = path.read_text(encoding="utf-8", errors="replace")
    for match in INCLUDE.finditer(text):
        target = match.group(1)
        where = f"{rel}:{text.count(chr(10), 0, match.start()) + 1}"
        if target.startswith("tsdf_mcl/"):
            parts = target.split("/")
            if len(parts) < 3:
                findings.append(f"{where}: unqualified include {target} (use tsdf_mcl/<layer>/...)")
            elif parts[1] not in LINKS:
                findings.append(f"{where}: {target} names no layer")
            elif parts[1] not in allowed:
                who = f"layer {layer}" if layer else "frontend"
                findings.append(f"{where}: {who} includes {target} against the grain "
                                f"(allowed: {', '.join(sorted(allowed))})")
            continue
        # A private header: beside the file, or (wrongly) reached through src/ or a relative path.
        candidates = [(path.parent / target).resolve(), (src_root / target).resolve()]
        for resolved in candidates:
            if not resolved.is_file() or src_root not in resolved.parents:
                continue
            owner = resolved.relative_to(src_root).parts[0]
            if layer is None:
                findings.append(f"{where}: includes {target} from src/{owner} (use a public header or a support "
                                "folder of its own)")
            elif owner != layer:
                findings.append(f"{where}: reaches into the sources of layer {owner}: {target}")
            break


def check_includes(root, findings):
    for layer in LINKS:
        for folder in (root / "src" / layer, root / "include" / "tsdf_mcl" / layer):
            for path in source_files(folder):
                check_file(root, path, layer, findings)
    for folder in FRONTENDS:
        for path in source_files(root / folder):
            check_file(root, path, None, findings)


def check_cmake(root, findings):
    text = (root / "src" / "CMakeLists.txt").read_text()
    # A layer may be declared more than once (backends with and without Vulkan): its links are the union.
    calls = {}
    for m in re.finditer(r"^\s*tsdf_mcl_layer\((\w+)(.*?)\)\s*$", text, re.S | re.M):
        calls[m.group(1)] = calls.get(m.group(1), "") + " " + m.group(2)
    extra = {}
    for m in re.finditer(r"target_link_libraries\(tsdf_mcl_(\w+)\s(.*?)\)", text, re.S):
        extra[m.group(1)] = extra.get(m.group(1), "") + " " + m.group(2)
    for layer, deps in LINKS.items():
        if layer not in calls:
            findings.append(f"src/CMakeLists.txt: no tsdf_mcl_layer({layer} ...)")
            continue
        linked = set(re.findall(r"tsdf_mcl::(\w+)", calls[layer] + " " + extra.get(layer, "")))
        if linked != set(deps):
            findings.append(f"src/CMakeLists.txt: layer {layer} links {sorted(linked)}, LINKS says {sorted(deps)}")
    for layer in calls:
        if layer not in LINKS:
            findings.append(f"src/CMakeLists.txt: layer {layer} is missing from LINKS in tools/check_layers.py")


def check_docs(root, findings):
    rows = {}
    for m in re.finditer(r"^\| `(\w+)` \|.*\|([^|]*)\|\s*$", (root / "docs" / "architecture.md").read_text(), re.M):
        rows[m.group(1)] = set(re.findall(r"`(\w+)`", m.group(2))) & set(LINKS)
    for layer, deps in LINKS.items():
        if layer not in rows:
            findings.append(f"docs/architecture.md: the layer table has no row for `{layer}`")
        elif rows[layer] != set(deps):
            findings.append(f"docs/architecture.md: the table says `{layer}` links {sorted(rows[layer])}, "
                            f"LINKS says {sorted(deps)}")


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
    root = root.resolve()
    findings = []
    check_includes(root, findings)
    check_cmake(root, findings)
    check_docs(root, findings)
    for finding in findings:
        print(f"check_layers: {finding}", file=sys.stderr)
    if findings:
        return 1
    print(f"check_layers: {len(LINKS)} layers; every include follows their edges", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
