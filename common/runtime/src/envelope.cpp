#include "swarmloc/runtime/envelope.hpp"

namespace swarmloc::runtime {

const char* to_string(RejectReason reason) {
  switch (reason) {
    case RejectReason::kNonFinite:
      return "non_finite";
    case RejectReason::kNotSymmetricPsd:
      return "not_symmetric_psd";
    case RejectReason::kAbsurdMagnitude:
      return "absurd_magnitude";
    case RejectReason::kUnknownSender:
      return "unknown_sender";
    case RejectReason::kDuplicate:
      return "duplicate";
    case RejectReason::kReordered:
      return "reordered";
    case RejectReason::kMalformed:
      return "malformed";
    case RejectReason::kCount:
      break;
  }
  return "unknown";
}

}  // namespace swarmloc::runtime
