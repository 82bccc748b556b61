#pragma once
// Checked output moved to the runtime (an agent process writes its sample log with it).
#include "swarmloc/runtime/output_file.hpp"
