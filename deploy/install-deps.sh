#!/usr/bin/env bash
# Installs every Debian 12 package dome needs to build, test and run.
# Idempotent; run as root. See README.md ("Dependencies") for why each is here.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libzmq3-dev cppzmq-dev
  libprotobuf-dev protobuf-compiler
  libopencv-dev
  libeigen3-dev
  libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev
  libbenchmark-dev
  libcli11-dev
  libtiff-dev libpng-dev libjpeg-dev  # image files (io/image_codecs.h)
  libembree-dev
  python3-open3d python3-scipy python3-numpy
  libmeshoptimizer-dev python3-skimage
  libavcodec-dev libavutil-dev libswscale-dev  # dome export: the atlases as one H.264 stream (libx264)
  zlib1g-dev  # dome export: the CRC-32s of the 4D file's records
  blender  # the test that Blender imports `dome export --format gltf-sequence` as one animation
  libdraco-dev  # dome export: Draco's mesh coder for the 4D file (and bench/sequence)
  ffmpeg  # readvitc: the independent VITC decoder the capture tests check our encoder against
  libssl-dev  # SHA-256 content addresses of the runtime's blobs (libcrypto)
  libcpp-httplib-dev  # the HTTP server of `dome view` (a kept library, not hand-written sockets)
  libjs-three  # three.js r111 with its loaders and OrbitControls: the viewer page, offline
  chromium  # headless browser of the viewer's end-to-end test and benchmark
  python3-websocket  # the viewer test's DevTools-protocol client
  systemd  # systemd-analyze verify: the test of deploy/systemd units
  slurm-wlm munge  # a single-node Slurm for the test of deploy/slurm/dome-workers.sbatch
  openssh-server openssh-client  # sshd on loopback for the test of deploy/ssh/dome-ssh-workers
  libzstd-dev  # zstd: fusion slabs travel to the master compressed (fusion/volume.h)
  nlohmann-json3-dev  # the one JSON writer of reports and JSON lines (report.json, eval, fuse)
)

# npm, for the one web asset Debian lacks (Draco's decoder, viewer/package.json): Debian's
# npm unless a Node.js with npm is installed already.
command -v npm > /dev/null || packages+=(npm)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# Draco's WebAssembly decoder for the viewer's 4D player, at the version and hash
# viewer/package-lock.json pins (copied next to the page by the build).
(cd "$(dirname "$0")/../viewer" && npm ci --no-audit --no-fund --loglevel=error)
