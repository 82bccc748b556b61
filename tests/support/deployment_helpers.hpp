#pragma once
// Helpers for the deployment tests (containers, Compose, Kubernetes manifests, network-namespace hosts):
// what they need is root, podman and an image of this build, which a developer's machine may lack, so
// they skip without it — but CI sets SWARMLOC_TEST_REQUIRE_DEPLOYMENTS=1 (scripts/test), and there a
// missing prerequisite fails the test instead: a deployment path CI skips is a path CI does not test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "process_helpers.hpp"

namespace swarmloc::testing {

/// True when CI asked for every deployment test to run (SWARMLOC_TEST_REQUIRE_DEPLOYMENTS=1).
inline bool deployments_required() {
  const char* flag = std::getenv("SWARMLOC_TEST_REQUIRE_DEPLOYMENTS");
  return flag != nullptr && std::string(flag) == "1";
}

/// The podman image of this build that scripts/test makes (deploy/k8s/Containerfile.host-binary), or "".
inline std::string podman_test_image() {
  const char* image = std::getenv("SWARMLOC_TEST_PODMAN_IMAGE");
  return image == nullptr ? std::string() : std::string(image);
}

/// Empty when podman can run containers of SWARMLOC_TEST_PODMAN_IMAGE here, else why not.
inline std::string missing_podman_image() {
  if (::geteuid() != 0) return "needs root (podman networks, network namespaces)";
  if (run_command("podman --version").exit_code != 0) return "needs podman (scripts/install-deps.sh --test)";
  const std::string image = podman_test_image();
  if (image.empty())
    return "set SWARMLOC_TEST_PODMAN_IMAGE to a podman image of this build (scripts/test does)";
  if (run_command("podman image exists " + image).exit_code != 0) return "no podman image " + image;
  return {};
}

/// A containers.conf with modest default ulimits: without CAP_SYS_RESOURCE (this machine's hard nofile
/// limit is 20000) runc cannot raise a container's limits to podman's defaults
/// (deploy/container/README.md). Returns its path, for CONTAINERS_CONF.
inline std::string write_containers_conf(const std::filesystem::path& dir) {
  const auto path = dir / "containers.conf";
  std::ofstream(path) << "[containers]\ndefault_ulimits = [\"nofile=1024:1024\", \"nproc=4096:4096\"]\n";
  return path.string();
}

/// The last JSON object a container printed (the orchestrator prints summary.json last); null if none.
inline nlohmann::json last_json_object(const std::string& log) {
  const auto open = log.rfind("\n{\n");
  const auto close = log.rfind("\n}");
  if (open == std::string::npos || close == std::string::npos || close < open) return nullptr;
  return nlohmann::json::parse(log.substr(open + 1, close + 2 - (open + 1)), nullptr, false);
}

}  // namespace swarmloc::testing

/// GTEST_SKIP with the reason, or, when CI requires the deployment tests, a failure with it.
#define SWARMLOC_SKIP_DEPLOYMENT(why)                                                                        \
  do {                                                                                                       \
    if (::swarmloc::testing::deployments_required()) {                                                       \
      GTEST_FAIL() << "SWARMLOC_TEST_REQUIRE_DEPLOYMENTS=1, but this deployment test cannot run: " << (why); \
    }                                                                                                        \
    GTEST_SKIP() << (why);                                                                                   \
  } while (false)
