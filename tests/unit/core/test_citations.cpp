// The repository explains itself: every `docs/<file>.md` a source file cites exists, and every
// `docs/<file>.md §N.M` names a heading of that file (docs/algorithms.md keeps the specification's
// section numbers).
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
const fs::path kRoot = SWARMLOC_SOURCE_DIR;

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<fs::path> cited_sources() {
  static const std::set<std::string> kExtensions{".cpp", ".hpp", ".h",     ".c",
                                                 ".idl", ".sh",  ".cmake", ".yaml"};
  std::vector<fs::path> files;
  for (const char* folder : {"agent", "common", "orchestrator", "idl", "tests", "bench", "scripts", "deploy",
                             "scenarios", "cmake"}) {
    if (!fs::exists(kRoot / folder)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(kRoot / folder)) {
      if (entry.is_regular_file() && kExtensions.contains(entry.path().extension().string()))
        files.push_back(entry.path());
    }
  }
  return files;
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// True if `doc` has a Markdown heading numbered `section` ("## 2." for 2, "### 2.8 …" for 2.8).
bool has_section(const std::string& doc, const std::string& section) {
  for (std::size_t at = 0; (at = doc.find(section, at)) != std::string::npos; at += section.size()) {
    std::size_t hashes = at;
    while (hashes > 0 && doc[hashes - 1] == ' ') --hashes;
    const std::size_t spaces = at - hashes;
    std::size_t line = hashes;
    while (line > 0 && doc[line - 1] == '#') --line;
    const bool heading = spaces == 1 && line < hashes && (line == 0 || doc[line - 1] == '\n');
    const std::size_t after = at + section.size();
    if (heading && after < doc.size() && (doc[after] == '.' || doc[after] == ' ')) return true;
  }
  return false;
}

/// Each `docs/<file>.md`, with the `§N.M` after it if there is one ("" if not).
std::vector<std::pair<std::string, std::string>> citations(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> found;
  static const std::string kPrefix = "docs/";
  static const std::string kSection = "§";
  for (std::size_t at = 0; (at = text.find(kPrefix, at)) != std::string::npos; at += kPrefix.size()) {
    std::size_t end = at + kPrefix.size();
    const auto name_char = [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' || c == '/' || c == '-';
    };
    while (end < text.size() && name_char(text[end])) ++end;
    std::string file = text.substr(at + kPrefix.size(), end - at - kPrefix.size());
    while (!file.empty() && file.back() == '.') file.pop_back();  // a sentence's full stop
    if (file.size() < 4 || file.compare(file.size() - 3, 3, ".md") != 0) continue;
    std::size_t next = at + kPrefix.size() + file.size();
    while (next < text.size() && text[next] == ' ') ++next;
    std::string section;
    if (text.compare(next, kSection.size(), kSection) == 0) {
      next += kSection.size();
      while (next < text.size() && text[next] == ' ') ++next;
      while (next < text.size() && (is_digit(text[next]) || (text[next] == '.' && next + 1 < text.size() &&
                                                             is_digit(text[next + 1])))) {
        section += text[next++];
      }
    }
    found.emplace_back(file, section);
  }
  return found;
}

TEST(Citations, EveryCitedDocumentAndSectionExistsInTheRepository) {
  int documents = 0, sections = 0;
  for (const auto& file : cited_sources()) {
    for (const auto& [cited, section] : citations(read_text(file))) {
      const auto doc = kRoot / "docs" / cited;
      ASSERT_TRUE(fs::exists(doc)) << file << " cites docs/" << cited << ", which is not in the repository";
      ++documents;
      if (!section.empty()) {
        EXPECT_TRUE(has_section(read_text(doc), section))
            << file << " cites docs/" << cited << " §" << section << ": no such section heading";
        ++sections;
      }
    }
  }
  EXPECT_GT(documents, 100) << "the scan found too few citations to mean anything";
  EXPECT_GT(sections, 50);
}

TEST(Citations, NoSourceCitesTheSpecificationOutsideTheRepository) {
  for (const auto& file : cited_sources()) {
    const std::string text = read_text(file);
    // Spelled in pieces so that this file does not cite them itself.
    const std::string md = ".md";
    const std::string shared = "shared/";
    for (const std::string& outside :
         {"ALGORITHMS" + md, "DESIGN" + md, "STYLE" + md, shared + "docs/", shared + "reference/"}) {
      EXPECT_EQ(text.find(outside), std::string::npos) << file << " cites " << outside;
    }
  }
}

}  // namespace
