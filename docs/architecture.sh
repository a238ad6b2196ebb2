#!/usr/bin/env bash
# Draws docs/architecture.png, the libraries and programs of dome and what links what,
# from the CMake build graph (cmake --graphviz) reduced to its direct links (tred),
# bottom to top as cmake/layers.cmake orders them. Needs Debian's graphviz.
#   bash docs/architecture.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$build/CMakeGraphVizOptions.cmake" <<'CMAKE'
set(GRAPHVIZ_EXTERNAL_LIBS FALSE)
set(GRAPHVIZ_GENERATE_PER_TARGET FALSE)
set(GRAPHVIZ_GENERATE_DEPENDERS FALSE)
CMAKE
cmake -S "$root" -B "$build" --graphviz="$work/all.dot" > /dev/null
/usr/bin/python3 - "$work/all.dot" "$root/cmake/layers.cmake" > "$work/dome.dot" <<'PY'
import re, sys
dot, layers_file = open(sys.argv[1]).read(), open(sys.argv[2]).read()
layers = re.search(r"set\(DOME_LAYERS\s+([^)]*)\)", layers_file).group(1).split()
algorithms = re.search(r"set\(DOME_ALGORITHMS\s+([^)]*)\)", layers_file).group(1).split()
programs = ["dome", "dome-master", "dome-worker", "dome-capture"]
keep = {"dome_" + l for l in layers} | {"dome_proto"} | set(programs)
names = dict(re.findall(r'"(node\d+)" \[ label = "([^"]+)"', dot))
edges = {(names[a], names[b]) for a, b in re.findall(r'"(node\d+)" -> "(node\d+)"', dot)
         if names[a] in keep and names[b] in keep and names[a] != names[b]}
print("digraph dome {\n  rankdir=BT; nodesep=0.25; ranksep=0.35;")
print('  node [fontname="Helvetica", fontsize=11, style=filled, fillcolor="#dce8f5"];')
for l in layers:
    colour = "#dce8f5" if l in algorithms else "#f5e6c8"
    print(f'  "dome_{l}" [label="{l}", shape=box, fillcolor="{colour}"];')
print('  "dome_proto" [label="proto (generated)", shape=note, fillcolor="#eeeeee"];')
for p in programs:
    print(f'  "{p}" [shape=ellipse, fillcolor="#d5efd5"];')
for a, b in sorted(edges):
    print(f'  "{a}" -> "{b}";')
print('  label="blue: algorithm libraries (no generated protobuf type); sand: formats, '
      'network, pipeline, scheduler, worker, CLI; green: programs. An arrow: links. '
      '(docs/architecture.sh)"; fontsize=10;')
print("}")
PY
tred "$work/dome.dot" > "$work/reduced.dot"
dot -Tpng -Gdpi=90 "$work/reduced.dot" -o "$root/docs/architecture.png"
echo "wrote $root/docs/architecture.png"
