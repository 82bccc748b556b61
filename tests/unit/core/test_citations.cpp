// The repository explains itself: every `docs/<file>.md` a source file cites exists; every `§N.M` cited
// right after a document names a heading of that document (docs/algorithms.md keeps the specification's
// section numbers), in every form the tree uses: "docs/design.md §4", "docs/algorithms.md §1.3.1",
// "free-run-spread §2", "free-run-spread.md section 2", lists such as "§4.2, §4.5" and ranges such as
// "§2.1–§2.4"; and every interpretation tag such as `[B-6]` has its entry in the interpretation
// register, docs/algorithms.md §8.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
const fs::path kRoot = SWARMLOC_SOURCE_DIR;

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Source files, build files and scripts (extensionless files that start with `#!`).
std::vector<fs::path> cited_sources() {
  static const std::set<std::string> kExtensions{".cpp",   ".hpp",  ".h",  ".c",   ".idl", ".sh",
                                                 ".cmake", ".yaml", ".py", ".msg", ".xml"};
  const auto is_source = [](const fs::path& path) {
    if (kExtensions.contains(path.extension().string()) || path.filename() == "CMakeLists.txt") return true;
    return !path.has_extension() && read_text(path).starts_with("#!");
  };
  std::vector<fs::path> files{kRoot / "CMakeLists.txt"};
  for (const char* folder : {"agent", "common", "research", "orchestrator", "idl", "tests", "bench",
                             "scripts", "deploy", "scenarios", "cmake"}) {
    if (!fs::exists(kRoot / folder)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(kRoot / folder)) {
      if (entry.is_regular_file() && is_source(entry.path())) files.push_back(entry.path());
    }
  }
  return files;
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_upper(char c) { return c >= 'A' && c <= 'Z'; }
bool is_name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' || c == '/' || c == '-';
}
bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; }

/// True if `doc` has a Markdown heading numbered `section` ("## 2." for 2, "### 2.8 …" for 2.8, not
/// "### 2.8.1 …" for 2.8).
bool has_section(const std::string& doc, const std::string& section) {
  for (std::size_t at = 0; (at = doc.find(section, at)) != std::string::npos; at += section.size()) {
    std::size_t hashes = at;
    while (hashes > 0 && doc[hashes - 1] == ' ') --hashes;
    const std::size_t spaces = at - hashes;
    std::size_t line = hashes;
    while (line > 0 && doc[line - 1] == '#') --line;
    const bool heading = spaces == 1 && line < hashes && (line == 0 || doc[line - 1] == '\n');
    const std::size_t after = at + section.size();
    if (!heading || after >= doc.size()) continue;
    const bool ends_number =
        doc[after] == ' ' || (doc[after] == '.' && (after + 1 == doc.size() || !is_digit(doc[after + 1])));
    if (ends_number) return true;
  }
  return false;
}

/// Every document under docs/, by its path below docs/ ("scale.md", "measurements/free-run-spread.md").
std::vector<std::string> documents() {
  std::vector<std::string> docs;
  for (const auto& entry : fs::recursive_directory_iterator(kRoot / "docs")) {
    if (entry.is_regular_file() && entry.path().extension() == ".md")
      docs.push_back(entry.path().lexically_relative(kRoot / "docs").generic_string());
  }
  return docs;
}

/// The document under docs/ a short name stands for ("scale.md", "free-run-spread.md" or "free-run-spread"
/// for measurements/free-run-spread.md); "" if none or if the name is ambiguous.
std::string resolve_short_name(const std::string& name, const std::vector<std::string>& docs) {
  const std::string file = name.ends_with(".md") ? name : name + ".md";
  std::string found;
  for (const auto& doc : docs) {
    if (doc == file) return doc;
    if (doc.ends_with("/" + file)) {
      if (!found.empty()) return "";
      found = doc;
    }
  }
  return found;
}

struct Citation {
  std::string document;               ///< below docs/, as written
  bool in_docs = true;                ///< written as docs/<document>; else a short name such as scale.md
  std::vector<std::string> sections;  ///< every §N.M right after it
};

const std::string kSection = "§";
const std::string kEnDash = "–";

/// The length of the section mark at `at`: "§" or "section " before a number ("section 4"), else 0.
std::size_t mark_at(const std::string& text, std::size_t at) {
  if (text.compare(at, kSection.size(), kSection) == 0) return kSection.size();
  for (const std::string_view word : {std::string_view("section "), std::string_view("sections ")}) {
    if (text.compare(at, word.size(), word) == 0 && at + word.size() < text.size() &&
        is_digit(text[at + word.size()]))
      return word.size();
  }
  return 0;
}

/// The `§N.M` list that starts at `at` (after spaces): "§4.2, §4.5", "§2.1–§2.4", "§3 and §4", "section 4".
std::vector<std::string> sections_at(const std::string& text, std::size_t at) {
  std::vector<std::string> sections;
  while (at < text.size() && (text[at] == ' ' || text[at] == ',')) ++at;
  for (std::size_t mark = mark_at(text, at); mark != 0;) {
    at += mark;
    while (at < text.size() && text[at] == ' ') ++at;
    std::string section;
    while (at < text.size() &&
           (is_digit(text[at]) || (text[at] == '.' && at + 1 < text.size() && is_digit(text[at + 1])))) {
      section += text[at++];
    }
    if (section.empty()) break;
    sections.push_back(section);
    // A separator to the next § of the same list, if any.
    std::size_t next = at;
    for (std::size_t before = std::string::npos; before != next;) {
      before = next;
      while (next < text.size() && (text[next] == ' ' || text[next] == ',' || text[next] == '-')) ++next;
      for (const std::string_view separator : {std::string_view(kEnDash), std::string_view("and "),
                                               std::string_view("or "), std::string_view("to ")}) {
        if (text.compare(next, separator.size(), separator) == 0) next += separator.size();
      }
    }
    mark = text.compare(next, kSection.size(), kSection) == 0 ? kSection.size() : 0;
    at = next;
  }
  return sections;
}

/// Each `docs/<file>.md` with the `§N.M` list after it (empty if none), and each short document name
/// (`scale.md`, `free-run-spread`) that a `§N.M` or "section N" follows. `docs` lists the documents, for
/// the short names.
/// docs/<file>.md, with or without sections.
void add_path_citations(const std::string& text, std::vector<Citation>& found) {
  static const std::string kPrefix = "docs/";
  for (std::size_t at = 0; (at = text.find(kPrefix, at)) != std::string::npos; at += kPrefix.size()) {
    if (at > 0 && is_word_char(text[at - 1])) continue;  // e.g. "mydocs/"
    std::size_t end = at + kPrefix.size();
    while (end < text.size() && is_name_char(text[end])) ++end;
    std::string file = text.substr(at + kPrefix.size(), end - at - kPrefix.size());
    while (!file.empty() && file.back() == '.') file.pop_back();  // a sentence's full stop
    if (file.size() < 4 || !file.ends_with(".md")) continue;
    found.push_back({file, true, sections_at(text, at + kPrefix.size() + file.size())});
  }
}

/// A short name right before a section mark `mark`: "free-run-spread §2", "free-run-spread.md section 2".
void add_short_name_citations(const std::string& text, const std::string& mark,
                              const std::vector<std::string>& docs, std::vector<Citation>& found) {
  for (std::size_t at = 0; (at = text.find(mark, at)) != std::string::npos; at += mark.size()) {
    if (mark_at(text, at) == 0) continue;
    std::size_t end = at;
    while (end > 0 && (text[end - 1] == ' ' || text[end - 1] == ',')) --end;
    std::size_t start = end;
    while (start > 0 && is_name_char(text[start - 1])) --start;
    const std::string name = text.substr(start, end - start);
    if (name.empty() || name.find("docs/") != std::string::npos) continue;  // counted as a path
    if (name.ends_with(".md") || !resolve_short_name(name, docs).empty()) {
      // A list is read from its first mark; a later § of the same list has a § or a separator before it.
      found.push_back({name.ends_with(".md") ? name : name + ".md", false, sections_at(text, at)});
    }
  }
}

std::vector<Citation> citations(const std::string& text, const std::vector<std::string>& docs) {
  std::vector<Citation> found;
  add_path_citations(text, found);
  for (const std::string& mark : {kSection, std::string("section")})
    add_short_name_citations(text, mark, docs, found);
  return found;
}

/// Each interpretation tag `[X-N]` in `text` ("[B-6]"); `a[N-1]`, an index, is not one.
std::vector<std::string> tags(const std::string& text) {
  std::vector<std::string> found;
  for (std::size_t at = 0; (at = text.find('[', at)) != std::string::npos; ++at) {
    if (at > 0 && (is_word_char(text[at - 1]) || text[at - 1] == ']' || text[at - 1] == ')')) continue;
    std::size_t end = at + 1;
    if (end + 2 >= text.size() || !is_upper(text[end]) || text[end + 1] != '-' || !is_digit(text[end + 2]))
      continue;
    end += 2;
    while (end < text.size() && is_digit(text[end])) ++end;
    if (end < text.size() && text[end] == ']') found.push_back(text.substr(at, end + 1 - at));
  }
  return found;
}

/// The text of section `number` ("8") of a Markdown document: from its `## N.` heading to the next `## `.
std::string top_section(const std::string& doc, const std::string& number) {
  const std::string heading = "\n## " + number + ".";
  const std::size_t start = doc.find(heading);
  if (start == std::string::npos) return "";
  const std::size_t end = doc.find("\n## ", start + heading.size());
  return doc.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

TEST(Citations, TheScannerReadsEveryFormTheTreeUses) {
  // Spelled in pieces so that the scan of this file does not read them as citations.
  const std::vector<std::string> docs{"validation.md", "robustness.md", "measurements/free-run-spread.md"};
  const std::string s = kSection;
  const auto found = citations("see docs/validation.md " + s + "4.2, " + s + "4.5 and " + s + "2.1" +
                                   kEnDash + s + "2.4; robustness.md " + s + "3.2 or (free-run-spread " + s +
                                   "4). docs/scale.md. ros2.md " + "section 1.",
                               docs);
  ASSERT_EQ(found.size(), 5U);
  EXPECT_EQ(found[0].document, "validation.md");
  EXPECT_EQ(found[0].sections, (std::vector<std::string>{"4.2", "4.5", "2.1", "2.4"}));
  EXPECT_EQ(found[1].document, "scale.md");
  EXPECT_TRUE(found[1].sections.empty());
  EXPECT_EQ(found[2].document, "robustness.md");
  EXPECT_EQ(found[2].sections, std::vector<std::string>{"3.2"});
  EXPECT_EQ(found[3].document, "free-run-spread.md");
  EXPECT_EQ(found[3].sections, std::vector<std::string>{"4"});
  EXPECT_EQ(found[4].document, "ros2.md");
  EXPECT_EQ(found[4].sections, std::vector<std::string>{"1"});
  const std::string b = "[";
  EXPECT_EQ(tags("// " + b + "B-6], " + b + "E-12] (" + b + "A-1]); x[N-1], v[K-2] [b-1] [AB-1]"),
            (std::vector<std::string>{b + "B-6]", b + "E-12]", b + "A-1]"}));
  EXPECT_TRUE(has_section("## 1. One\n### 1.3.1 Deep\n", "1.3.1"));
  EXPECT_FALSE(has_section("## 1. One\n### 1.3.1 Deep\n", "1.3"));
}

TEST(Citations, EveryCitedDocumentAndSectionExistsInTheRepository) {
  const auto docs = documents();
  std::map<std::string, std::string> texts;
  int documents_cited = 0, sections = 0, short_names = 0;
  for (const auto& file : cited_sources()) {
    for (const auto& cited : citations(read_text(file), docs)) {
      const std::string document = cited.in_docs ? cited.document : resolve_short_name(cited.document, docs);
      ASSERT_FALSE(document.empty()) << file << " cites " << cited.document << " §" << cited.sections.front()
                                     << ", which is not a document under docs/ (or names more than one)";
      const auto doc = kRoot / "docs" / document;
      ASSERT_TRUE(fs::exists(doc)) << file << " cites docs/" << document
                                   << ", which is not in the repository";
      if (cited.in_docs)
        ++documents_cited;
      else
        ++short_names;
      if (!texts.contains(document)) texts[document] = read_text(doc);
      for (const auto& section : cited.sections) {
        EXPECT_TRUE(has_section(texts[document], section))
            << file << " cites docs/" << document << " §" << section << ": no such section heading";
        ++sections;
      }
    }
  }
  EXPECT_GT(documents_cited, 100) << "the scan found too few citations to mean anything";
  EXPECT_GT(sections, 50);
  RecordProperty("documents", documents_cited);
  RecordProperty("short_names", short_names);
  RecordProperty("sections", sections);
}

TEST(Citations, EveryInterpretationTagHasItsEntryInTheRegister) {
  const std::string doc = read_text(kRoot / "docs/algorithms.md");
  const std::string register_ = top_section(doc, "8");
  ASSERT_NE(register_.find("Interpretation register"), std::string::npos)
      << "docs/algorithms.md §8 is no longer the interpretation register";
  int cited = 0;
  for (const auto& file : cited_sources()) {
    for (const auto& tag : tags(read_text(file))) {
      EXPECT_NE(register_.find("**" + tag + "**"), std::string::npos)
          << file << " cites " << tag << ", which has no entry **" << tag << "** in docs/algorithms.md §8";
      ++cited;
    }
  }
  EXPECT_GT(cited, 50) << "the scan found too few interpretation tags to mean anything";
  RecordProperty("tags", cited);
}

/// The names by which a source would cite the specification outside the repository: its documents
/// carry the names of ours (docs/algorithms.md, docs/design.md, docs/style.md) in capitals. Built, not
/// written out, so that this file does not cite them itself.
std::vector<std::string> outside_documents() {
  const std::string shared = "shared/";
  const std::string md = ".md";
  std::vector<std::string> names{shared + "docs/", shared + "reference/", "reference/discovery" + md};
  for (std::string name : {"algorithms", "design", "style"}) {
    std::ranges::transform(name, name.begin(),
                           [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    names.push_back(name + md);
  }
  return names;
}

TEST(Citations, NoSourceCitesTheSpecificationOutsideTheRepository) {
  const std::string shared = "shared/";
  const std::vector<std::string> outside_names = outside_documents();
  for (const auto& file : cited_sources()) {
    const std::string text = read_text(file);
    for (const std::string& outside : outside_names) {
      EXPECT_EQ(text.find(outside), std::string::npos) << file << " cites " << outside;
    }
    // Product code names no path outside the checkout either (the tests may look for the datasets
    // there: tests/support/dataset_paths.hpp).
    const bool is_test = file.lexically_relative(kRoot).begin()->string() == "tests";
    if (!is_test) {
      EXPECT_EQ(text.find("../" + shared), std::string::npos) << file << " names ../" << shared;
    }
  }
}

}  // namespace
