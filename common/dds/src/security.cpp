// DDS Security files of one participant (deploy/security/make-pki.sh lays them out).
#include <filesystem>
#include <string>

#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {

std::string security_participant(AgentId self) {
  if (self == kOrchestratorId) return "orchestrator";
  if (self == kFusionCenterId) return "fusion";
  return "agent-" + std::to_string(self);
}

SecurityFiles security_files(const std::string& dir, AgentId self) {
  namespace fs = std::filesystem;
  const std::string key = "dds.security_dir: ";
  std::error_code error;
  const fs::path root = fs::absolute(dir, error);
  if (error || !fs::is_directory(root, error)) {
    throw config::ScenarioError(key + "'" + dir +
                                "' is not a folder (make one with deploy/security/make-pki.sh DIR N)");
  }
  const fs::path own = root / security_participant(self);
  const auto need = [&](const fs::path& path) {
    std::error_code ignored;
    if (!fs::is_regular_file(path, ignored)) {
      throw config::ScenarioError(key + "'" + path.string() + "' is missing (" + security_participant(self) +
                                  "'s DDS Security files; deploy/security/make-pki.sh DIR N makes them)");
    }
    return path.lexically_normal().string();
  };
  SecurityFiles files;
  files.identity_ca = need(root / "identity_ca.pem");
  files.permissions_ca = need(root / "permissions_ca.pem");
  files.governance = need(root / "governance.p7s");
  files.certificate = need(own / "cert.pem");
  files.private_key = need(own / "key.pem");
  files.permissions = need(own / "permissions.p7s");
  return files;
}

}  // namespace swarmloc::dds
