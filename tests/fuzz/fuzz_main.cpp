// swarmloc_fuzz: runs the seeded random-mutation fuzz targets from the command line.
//   swarmloc_fuzz --inputs 1000000 --seed 1                 # every target
//   swarmloc_fuzz --target scenario --inputs 1000 --first 4711  # reproduce input 4711 onwards
// Prints one line per target (inputs, accepted, rejected, violations, wall time); exit code 1 on any
// violation. A crash or sanitizer report ends the process (run it in the ASan+UBSan build for those).
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "fuzz_targets.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "swarmloc_fuzz: seeded random-mutation fuzzing of the DDS sample decoders and the scenario parser"};
  std::uint64_t inputs = 10000;
  std::uint64_t seed = 1;
  std::uint64_t first = 0;
  std::vector<std::string> targets;
  app.add_option("--inputs", inputs, "Inputs per target");
  app.add_option("--seed", seed, "Seed (input i of a target depends only on seed, target and i)");
  app.add_option("--first", first, "Index of the first input (to reproduce a reported input)");
  app.add_option("--target", targets, "Target(s) to run (repeatable); default: all")
      ->check(CLI::IsMember(swarmloc::fuzz::target_names()));
  bool print = false;
  app.add_flag("--print", print, "Print scenario input --first (text, then overrides) and exit");
  CLI11_PARSE(app, argc, argv);
  if (print) {
    const auto input = swarmloc::fuzz::scenario_input(seed, first);
    std::fwrite(input.text.data(), 1, input.text.size(), stdout);
    for (const auto& text : input.overrides) std::printf("\n--set %s", text.c_str());
    std::printf("\n");
    return 0;
  }
  if (targets.empty()) targets = swarmloc::fuzz::target_names();

  std::uint64_t violations = 0;
  std::uint64_t total = 0;
  const auto all_started = std::chrono::steady_clock::now();
  for (const auto& target : targets) {
    const auto started = std::chrono::steady_clock::now();
    const auto result = swarmloc::fuzz::run_target(target, seed, inputs, first);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::printf("%-12s inputs %llu  accepted %llu  rejected %llu  violations %llu  wall %.1f s\n",
                target.c_str(), static_cast<unsigned long long>(result.inputs),
                static_cast<unsigned long long>(result.accepted),
                static_cast<unsigned long long>(result.rejected),
                static_cast<unsigned long long>(result.violations), wall_s);
    for (const auto& failure : result.failures) std::printf("  %s\n", failure.c_str());
    std::fflush(stdout);
    violations += result.violations;
    total += result.inputs;
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - all_started).count();
  std::printf("total        inputs %llu  violations %llu  wall %.1f s  (seed %llu)\n",
              static_cast<unsigned long long>(total), static_cast<unsigned long long>(violations), wall_s,
              static_cast<unsigned long long>(seed));
  return violations == 0 ? 0 : 1;
}
