#include "entities.hpp"

#include <map>
#include <mutex>

namespace swarmloc::dds {

dds_return_t check(dds_return_t rc, std::string_view operation, std::string_view subject) {
  if (rc < 0) {
    std::string message(operation);
    if (!subject.empty()) message.append(" ").append(subject);
    message.append(": ").append(dds_strretcode(rc));
    throw DdsError(message);
  }
  return rc;
}

Entity& Entity::operator=(Entity&& other) noexcept {
  if (this != &other) {
    reset();
    handle_ = other.handle_;
    other.handle_ = 0;
  }
  return *this;
}

void Entity::reset() {
  if (handle_ > 0) {
    // Errors here (e.g. the entity was already deleted together with its domain) are not actionable.
    static_cast<void>(dds_delete(handle_));
  }
  handle_ = 0;
}

namespace {

struct DomainEntry {
  dds_entity_t handle = 0;  ///< 0 if the domain already existed (created implicitly elsewhere)
  std::string xml;
  int leases = 0;
};

std::mutex& registry_mutex() {
  static std::mutex mutex;
  return mutex;
}

std::map<dds_domainid_t, DomainEntry>& registry() {
  static std::map<dds_domainid_t, DomainEntry> domains;
  return domains;
}

}  // namespace

DomainLease::DomainLease(dds_domainid_t domain_id, const std::string& xml) : domain_id_(domain_id) {
  const std::lock_guard lock(registry_mutex());
  auto& domains = registry();
  auto found = domains.find(domain_id);
  if (found != domains.end()) {
    ++found->second.leases;
    config_applied_ = found->second.xml == xml;
    return;
  }
  DomainEntry entry;
  entry.xml = xml;
  entry.leases = 1;
  const dds_entity_t handle = dds_create_domain(domain_id, xml.c_str());
  if (handle == DDS_RETCODE_PRECONDITION_NOT_MET) {
    // Created outside this registry (e.g. implicitly by a bare dds_create_participant): share it.
    entry.handle = 0;
    config_applied_ = false;
  } else {
    check(handle, "dds_create_domain (check the Cyclone XML from cyclone_config)");
    entry.handle = handle;
    config_applied_ = true;
  }
  domains.emplace(domain_id, std::move(entry));
}

DomainLease::~DomainLease() {
  const std::lock_guard lock(registry_mutex());
  auto& domains = registry();
  auto found = domains.find(domain_id_);
  if (found == domains.end()) {
    return;
  }
  if (--found->second.leases == 0) {
    if (found->second.handle > 0) {
      static_cast<void>(dds_delete(found->second.handle));
    }
    domains.erase(found);
  }
}

}  // namespace swarmloc::dds
