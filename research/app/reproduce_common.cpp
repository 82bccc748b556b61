#include "reproduce_common.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "reference_tables.hpp"

namespace swarmloc::research::reproduce_detail {

int resolve_threads(int threads) {
  return threads > 0 ? threads : static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
}

void emit(const std::filesystem::path& out_dir, const std::string& name, const std::string& markdown) {
  std::filesystem::create_directories(out_dir);
  std::ofstream(out_dir / (name + ".md")) << markdown;
  std::printf("%s\n(written to %s)\n", markdown.c_str(), (out_dir / (name + ".md")).c_str());
}

std::string fmt(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

double seconds_since(std::chrono::steady_clock::time_point started) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
}

namespace {

/// Comma-separated fields; a field in double quotes may hold commas.
std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (const char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

}  // namespace

ReferenceTable ReferenceTable::parse(const std::string& name, const std::string& csv) {
  ReferenceTable table;
  table.name_ = name;
  std::stringstream in(csv);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line.front() == '#') continue;
    auto fields = split_fields(line);
    if (table.header_.empty()) {
      table.header_ = std::move(fields);
      continue;
    }
    if (fields.size() != table.header_.size()) {
      throw std::logic_error("reference table " + name + ": a row of " + std::to_string(fields.size()) +
                             " fields under a header of " + std::to_string(table.header_.size()));
    }
    table.rows_.push_back(std::move(fields));
  }
  return table;
}

const ReferenceTable& ReferenceTable::get(const std::string& name) {
  static const auto tables = [] {
    std::map<std::string, ReferenceTable> parsed;
    for (const auto& [file, csv] : embedded_reference_tables()) {
      const auto stem = std::filesystem::path(file).stem().string();
      parsed.emplace(stem, parse(stem, std::string(csv)));
    }
    return parsed;
  }();
  const auto found = tables.find(name);
  if (found == tables.end()) throw std::logic_error("no reference table " + name);
  return found->second;
}

const std::string& ReferenceTable::text(std::size_t row, const std::string& column) const {
  const auto at = std::find(header_.begin(), header_.end(), column);
  if (at == header_.end()) throw std::logic_error("reference table " + name_ + ": no column " + column);
  return rows_.at(row)[static_cast<std::size_t>(at - header_.begin())];
}

double ReferenceTable::number(std::size_t row, const std::string& column, double if_empty) const {
  const auto& field = text(row, column);
  if (field.empty()) return if_empty;
  char* end = nullptr;
  const double value = std::strtod(field.c_str(), &end);
  if (end == field.c_str() || *end != '\0') {
    throw std::logic_error("reference table " + name_ + ": '" + field + "' in column " + column +
                           " is not a number");
  }
  return value;
}

}  // namespace swarmloc::research::reproduce_detail
