#pragma once
// CPU seconds this process or thread has used (user + system): for the reports agents and the fusion
// centre send, and the world loop's step profile.

namespace swarmloc::runtime {

double process_cpu_s();

/// The calling thread only.
double thread_cpu_s();

}  // namespace swarmloc::runtime
