#!/usr/bin/python3
"""Checks every library's #include lines against the layer order (cmake/layers.cmake).

  check_includes.py SOURCE_DIR --layers NAME... --algorithms NAME... --peers NAME...

A file of library L (common/L/, or a program's folder: master/ is `scheduler`,
worker/ `worker`, capture-agent/ `capture_agent`, cli/ `cli`) may include headers of
L and of the libraries before it in --layers only; peers include neither each other;
an algorithm library includes no generated protobuf header (*.pb.h). Prints every
violation as FILE:LINE and exits 1 when there is one.
"""
import argparse
import os
import re
import sys

PROGRAMS = {"master": "scheduler", "worker": "worker", "capture-agent": "capture_agent",
            "cli": "cli"}


def library_of(rel):
    """The library a source path (relative to the root) or an include path belongs to."""
    parts = rel.split("/")
    if parts[0] == "common" and len(parts) > 2:
        return parts[1]
    if parts[0] in PROGRAMS:
        return PROGRAMS[parts[0]]
    return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("root")
    ap.add_argument("--layers", nargs="+", required=True)
    ap.add_argument("--algorithms", nargs="+", required=True)
    ap.add_argument("--peers", nargs="*", default=[])
    args = ap.parse_args()
    level = {name: i for i, name in enumerate(args.layers)}
    include = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
    problems, files = [], 0
    for top in ["common"] + list(PROGRAMS):
        for dirpath, _, names in os.walk(os.path.join(args.root, top)):
            for name in sorted(names):
                if not name.endswith((".h", ".cc")):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, args.root)
                lib = library_of(rel)
                if lib is None or lib not in level:
                    problems.append(f"{rel}: in no library of the layer order")
                    continue
                files += 1
                with open(path, encoding="utf-8") as f:
                    for n, line in enumerate(f, 1):
                        m = include.match(line)
                        if not m:
                            continue
                        header = m.group(1)
                        where = f"{rel}:{n}: includes {header}"
                        if header.endswith(".pb.h"):
                            if lib in args.algorithms:
                                problems.append(f"{where}: a generated protobuf header in the "
                                                f"algorithm library {lib}")
                            continue
                        # Headers are included by their folder: common/<lib>/x.h as
                        # "<lib>/x.h", a program's as "<folder>/x.h".
                        first = header.split("/")[0]
                        other = PROGRAMS.get(first, first if first in level else None)
                        if other is None:
                            continue  # a system or third-party header
                        if other != lib and lib in args.peers and other in args.peers:
                            problems.append(f"{where}: {lib} and {other} are peers on the "
                                            f"wire and include neither each other")
                        elif level[other] > level[lib]:
                            problems.append(f"{where}: {other} is above {lib} in the layer "
                                            f"order")
    for p in problems:
        print(p)
    print(f"{files} files checked, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
