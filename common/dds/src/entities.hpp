#pragma once
// RAII and error handling around Cyclone's C API (private to common/dds/src).
#include <dds/dds.h>

#include <string>
#include <string_view>

#include "swarmloc/dds/transport.hpp"

namespace swarmloc::dds {

/// Throws DdsError("<operation> <subject>: <dds_strretcode>") when rc is negative; returns rc otherwise.
/// The message is built only on failure (dds_write checks every sample).
dds_return_t check(dds_return_t rc, std::string_view operation, std::string_view subject = {});

/// Owns one dds_entity_t; deletes it (and, by Cyclone's rules, all its children) on destruction.
class Entity {
 public:
  Entity() = default;
  explicit Entity(dds_entity_t handle) : handle_(handle) {}
  ~Entity() { reset(); }
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
  Entity(Entity&& other) noexcept : handle_(other.handle_) { other.handle_ = 0; }
  Entity& operator=(Entity&& other) noexcept;

  [[nodiscard]] dds_entity_t get() const { return handle_; }
  void reset();

 private:
  dds_entity_t handle_ = 0;
};

/// A share of a process-wide Cyclone domain. Cyclone allows one domain instance per domain id per
/// process (a second dds_create_domain with the same id fails with PRECONDITION_NOT_MET, and every
/// participant of that id attaches to the first one's configuration). The lease is reference-counted
/// so that deleting one transport never deletes a domain another transport in the process still uses.
class DomainLease {
 public:
  /// Creates the domain with `xml` if this process has none for `domain_id` yet; otherwise shares the
  /// existing one (its configuration wins; config_applied() tells which happened).
  DomainLease(dds_domainid_t domain_id, const std::string& xml);
  ~DomainLease();
  DomainLease(const DomainLease&) = delete;
  DomainLease& operator=(const DomainLease&) = delete;

  [[nodiscard]] dds_domainid_t domain_id() const { return domain_id_; }
  /// True if `xml` is the configuration in force (this lease created the domain, or the existing
  /// domain was created from identical text).
  [[nodiscard]] bool config_applied() const { return config_applied_; }

 private:
  dds_domainid_t domain_id_;
  bool config_applied_ = false;
};

}  // namespace swarmloc::dds
