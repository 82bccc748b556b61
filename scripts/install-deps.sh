#!/usr/bin/env bash
# Installs what swarmloc needs from Debian's packages (bookworm). Idempotent: installs only what is
# missing, and uses sudo when not root.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  clang-format git                         # the clang_format test (scripts/check-format)
  clang-tidy                               # scripts/tidy (function size, complexity; .clang-tidy)
  cyclonedds-dev cyclonedds-tools          # Cyclone DDS 0.10.2 C API, idlc, ddsperf
  libddsc0debian openssl                   # DDS Security plugins (libdds_security_*.so); PKI script
  libeigen3-dev libspdlog-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  zlib1g-dev                               # gzip-compressed datasets (UTIAS MRCLAM)
  libsdpa-dev                              # SDPA (pulls MUMPS seq, OpenBLAS): SDP relaxation of Calafiore et al.
  gnuplot-nox                              # plots in every run directory
  procps                                   # pgrep/ps for the orphan-process checks in tests
  nftables iproute2                        # network namespaces + bridge loss for the multi-host test
  libcpp-httplib-dev                       # HTTP server of the live view (swarmloc run|sim --view)
  chromium fonts-dejavu-core               # headless browser (+ a font) for the live-view page test
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: everything is installed"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
