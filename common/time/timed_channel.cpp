#include "common/time/timed_channel.hpp"

namespace fieldline {

const char* toString(InsertResult r) {
  switch (r) {
    case InsertResult::kAccepted:
      return "accepted";
    case InsertResult::kOutOfOrder:
      return "out_of_order";
    case InsertResult::kTooOld:
      return "too_old";
    case InsertResult::kFromFuture:
      return "from_future";
    case InsertResult::kDuplicate:
      return "duplicate";
  }
  return "unknown";
}

}  // namespace fieldline
