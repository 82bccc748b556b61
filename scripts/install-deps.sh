#!/usr/bin/env bash
# Installs what swarmloc needs from Debian's packages (bookworm). Idempotent: installs only what is
# missing, and uses sudo when not root.
#
#   scripts/install-deps.sh          what building and running the product needs (`swarmloc`,
#                                    `swarmloc-agent`; scripts/run-default)
#   scripts/install-deps.sh --test   that, plus what building and running the whole test suite needs
#                                    (scripts/test, CI): GoogleTest, Google Benchmark, SDPA (research/),
#                                    the style tools, network namespaces, podman, headless chromium
set -euo pipefail

with_test=0
case "${1:-}" in
  "") ;;
  --test) with_test=1 ;;
  *) echo "usage: $0 [--test]" >&2; exit 2 ;;
esac

# Building and running: the compiler, CMake, and the libraries `swarmloc` and `swarmloc-agent` link.
run_packages=(
  build-essential cmake ninja-build pkg-config
  cyclonedds-dev cyclonedds-tools          # Cyclone DDS 0.10.2 C API, idlc (code generation), ddsperf
  libddsc0debian openssl                   # DDS Security plugins (libdds_security_*.so); make-pki.sh
  libeigen3-dev libspdlog-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  zlib1g-dev                               # gzip-compressed datasets (UTIAS MRCLAM)
  libcpp-httplib-dev                       # HTTP server of the live view (swarmloc run|sim --view)
  gnuplot-nox                              # plots in every run directory
)
# Testing: research/ (swarmloc-research, which the tests and benchmarks use), the test frameworks, the
# style checks, and what the integration tests drive.
test_packages=(
  libgtest-dev libgmock-dev libbenchmark-dev
  libsdpa-dev                              # SDPA (pulls MUMPS seq, OpenBLAS): SDP relaxation of Calafiore et al. (research/)
  clang-format git                         # the clang_format test (scripts/check-format)
  clang-tidy                               # scripts/tidy (function size, complexity; .clang-tidy)
  procps                                   # pgrep/ps for the orphan-process checks in tests
  nftables iproute2                        # network namespaces + bridge loss for the multi-host tests
  ethtool                                  # checksum offload off on the hosts behind the WiFi-like switch
  chromium fonts-dejavu-core               # headless browser (+ a font) for the live-view page test
  # The deployment tests (scripts/test, "deployments"): podman with runc (crun fails on cgroup v1 hosts,
  # deploy/container/README.md), catatonit for the pods' local pause image, podman-compose for
  # deploy/compose, the CNI dnsname plugin for deploy/k8s/podman-play.sh's DNS, debootstrap for the
  # registry-free base image (deploy/container/make-base.sh), python3-yaml for podman-play.sh.
  podman runc catatonit podman-compose golang-github-containernetworking-plugin-dnsname
  containernetworking-plugins debootstrap python3-yaml
)

packages=("${run_packages[@]}")
if ((with_test)); then packages+=("${test_packages[@]}"); fi

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
