// The repository explains itself: every `docs/<file>.md` a source file cites exists, and every
// `docs/<file>.md §N.M` names a heading of that file (docs/algorithms.md keeps the specification's
// section numbers).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <string>
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

/// True if `doc` has a Markdown heading numbered `section` ("## 2." for 2, "### 2.8 …" for 2.8).
bool has_section(const std::string& doc, const std::string& section) {
  const std::regex heading("(^|\n)#+ " + std::regex_replace(section, std::regex("\\."), "\\.") + "[. ]");
  return std::regex_search(doc, heading);
}

TEST(Citations, EveryCitedDocumentAndSectionExistsInTheRepository) {
  const std::regex citation(R"(docs/([A-Za-z0-9_./-]+\.md)(\s*§\s*([0-9]+(\.[0-9]+)*))?)");
  int documents = 0, sections = 0;
  for (const auto& file : cited_sources()) {
    const std::string text = read_text(file);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), citation); it != std::sregex_iterator();
         ++it) {
      const auto doc = kRoot / "docs" / (*it)[1].str();
      ASSERT_TRUE(fs::exists(doc)) << file << " cites " << (*it)[0] << ", which is not in the repository";
      ++documents;
      if ((*it)[3].matched) {
        EXPECT_TRUE(has_section(read_text(doc), (*it)[3].str()))
            << file << " cites " << (*it)[0] << ": no such section heading";
        ++sections;
      }
    }
  }
  EXPECT_GT(documents, 100) << "the scan found too few citations to mean anything";
  EXPECT_GT(sections, 50);
}

TEST(Citations, NoSourceCitesTheSpecificationOutsideTheRepository) {
  const std::regex outside(R"((^|[^/\w.])(ALGORITHMS|DESIGN|STYLE)\.md|shared/(docs|reference)/)");
  for (const auto& file : cited_sources()) {
    const std::string text = read_text(file);
    std::smatch match;
    EXPECT_FALSE(std::regex_search(text, match, outside)) << file << " cites " << match.str(0);
  }
}

}  // namespace
