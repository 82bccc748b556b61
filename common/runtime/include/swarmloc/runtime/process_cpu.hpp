#pragma once
// CPU seconds this process has used (user + system), for the reports agents and the fusion centre send.

namespace swarmloc::runtime {

double process_cpu_s();

}  // namespace swarmloc::runtime
