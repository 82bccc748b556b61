// The repository explains itself: every `docs/<file>.md` a source file cites exists; every `§N.M` cited
// right after a document names a heading of that document (docs/algorithms.md keeps the specification's
// section numbers), in every form the tree uses: "docs/design.md §4", "docs/algorithms.md §1.3.1",
// "free-run-spread §2", "free-run-spread.md section 2", lists such as "§4.2, §4.5" and ranges such as
// "§2.1–§2.4"; every interpretation tag such as `[B-6]` has its entry in the interpretation register,
// docs/algorithms.md §8; every repository path the code, the docs and the READMEs cite exists (the path
// forms are those of resolve_cited_path below); every paper is cited by a tag of docs/papers.md, never
// by its number or by the file name of a plain-text copy; and docs/README.md lists every page under docs/.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <initializer_list>
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

// ---- Cited repository paths ----

/// The repository's top folders: a path that starts with one of them is a repository path.
const std::set<std::string> kTopFolders{"agent", "bench",        "cmake",    "common",    "deploy",  "docs",
                                        "idl",   "orchestrator", "research", "scenarios", "scripts", "tests"};

/// Every Markdown page the repository ships: README.md, the READMEs beside the code and every page under
/// docs/.
std::vector<fs::path> markdown_pages() {
  std::vector<fs::path> pages{kRoot / "README.md"};
  for (const auto& folder : kTopFolders) {
    if (!fs::exists(kRoot / folder)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(kRoot / folder)) {
      if (entry.is_regular_file() && entry.path().extension() == ".md") pages.push_back(entry.path());
    }
  }
  return pages;
}

/// What the path and paper checks read: the sources and the Markdown pages.
std::vector<fs::path> cited_texts() {
  auto files = cited_sources();
  const auto pages = markdown_pages();
  files.insert(files.end(), pages.begin(), pages.end());
  return files;
}

/// The libraries under common/ ("core", "runtime", …), read from the tree.
std::set<std::string> libraries() {
  std::set<std::string> found;
  for (const auto& entry : fs::directory_iterator(kRoot / "common")) {
    if (entry.is_directory()) found.insert(entry.path().filename().string());
  }
  return found;
}

bool is_path_char(char c) { return is_name_char(c) || c == '+'; }

/// True if `at` lies on an `#include` line (the compiler checks those paths).
bool on_include_line(const std::string& text, std::size_t at) {
  const std::size_t newline = text.rfind('\n', at);
  std::size_t start = newline == std::string::npos ? 0 : newline + 1;
  while (start < text.size() && text[start] == ' ') ++start;
  return text.compare(start, 8, "#include") == 0;
}

/// Each path-like token of `text` that holds a '/': a maximal run of path characters without a trailing
/// full stop or hyphen. Left out: a token glued to what makes it something else — a URL or an absolute
/// path ("https://…", "/work/…"), a home or variable path ("~/…", "${DIR}/…", "$HOME/…"), a pattern or a
/// placeholder ("tests/unit/<lib>/", "agent_node.{hpp,cpp}", "common/*/src") — and the paths of #include
/// lines.
std::vector<std::string> path_tokens(const std::string& text) {
  static const std::string_view kGlued = "~$}{@*<>\\";
  std::vector<std::string> found;
  for (std::size_t at = 0; at < text.size();) {
    if (!is_path_char(text[at])) {
      ++at;
      continue;
    }
    std::size_t end = at;
    while (end < text.size() && is_path_char(text[end])) ++end;
    std::string token = text.substr(at, end - at);
    const char before = at > 0 ? text[at - 1] : ' ';
    const char after = end < text.size() ? text[end] : ' ';
    const bool include = on_include_line(text, at);
    at = end;
    while (!token.empty() && (token.back() == '.' || token.back() == '-')) token.pop_back();
    const bool glued =
        kGlued.find(before) != std::string_view::npos || kGlued.find(after) != std::string_view::npos;
    if (token.find('/') == std::string::npos || token.front() == '/' || glued || include) continue;
    found.push_back(token);
  }
  return found;
}

/// True if the last name of `path` has an extension ("world.cpp", "CMakeLists.txt"; not "test", "src/").
bool has_extension(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  const std::string name = path.substr(slash == std::string::npos ? 0 : slash + 1);
  const std::size_t dot = name.rfind('.');
  return dot != std::string::npos && dot > 0 && dot + 1 < name.size();
}

struct CitedPath {
  bool counted = false;           ///< a repository path by the forms below
  bool library_relative = false;  ///< written from a library folder or as an include path
  bool exists = false;
};

/// File names that make a path a source file wherever it starts (a launcher `scale.py` in a folder).
const std::set<std::string> kSourceExtensions{".cpp", ".hpp", ".h", ".c", ".py", ".sh", ".cmake", ".idl"};

/// Whether `token`, cited in `citing_file`, is a repository path and whether it exists. Counted:
/// - a path from a top folder that names a file with an extension ("common/world/src/world.cpp",
///   "docs/img/scale.png"), a folder with a trailing '/' ("tests/unit/"), a script ("scripts/test") or a
///   folder of common/ ("common/sim"); not other extensionless names, which are prose ("agent/fusion
///   centre") or built programs ("tests/ros2_reader/ros2_reader");
/// - a path from a library folder of common/ that names a file with an extension
///   ("runtime/agent_loop.hpp", "sim/agent_clock_simulator.cpp", "estimators/gradient/dgbb.hpp"), looked
///   up in the library's include/swarmloc/<lib>/, src/ and own folder, and an include path
///   ("swarmloc/world/world.hpp");
/// - any other path that names a source file, as a build file or a comment writes it from where it
///   stands: it must exist from the citing file's folder or from one of the folders above it
///   (the sources research/CMakeLists.txt lists from its app folder, common/dds/src's include/swarmloc/…);
/// - in a Markdown page, a "./" or "../" path that stays inside the repository, relative to the page.
CitedPath resolve_cited_path(std::string token, const fs::path& citing_file,
                             const std::set<std::string>& libs) {
  if (token.starts_with("./") || token.starts_with("../")) {
    if (citing_file.extension() != ".md") return {};  // in code, a path at run time
    const auto relative = (citing_file.parent_path() / token).lexically_normal().lexically_relative(kRoot);
    if (relative.empty() || *relative.begin() == "..") return {};
    token = relative.generic_string();
  }
  const std::size_t slash = token.find('/');
  const std::string first = token.substr(0, slash);
  const std::string rest = token.substr(slash + 1);
  const bool file = has_extension(token);
  if (kTopFolders.contains(first)) {
    const bool counted = file || token.ends_with("/") || first == "scripts" || first == "common";
    return {counted, false, counted && fs::exists(kRoot / token)};
  }
  if (!file) return {};
  std::vector<fs::path> candidates;
  if (libs.contains(first)) {
    const auto lib = kRoot / "common" / first;
    candidates = {lib / "include/swarmloc" / first / rest, lib / "src" / rest, lib / rest};
  } else if (first == "swarmloc" && rest.find('/') != std::string::npos) {
    const std::string lib = rest.substr(0, rest.find('/'));
    candidates = {kRoot / "common" / lib / "include" / token, kRoot / lib / "include" / token};
  } else if (kSourceExtensions.contains(fs::path(token).extension().string())) {
    for (fs::path folder = citing_file.parent_path(); folder.string().size() >= kRoot.string().size();
         folder = folder.parent_path()) {
      candidates.push_back(folder / token);
    }
  } else {
    return {};
  }
  const bool exists = std::ranges::any_of(candidates, [](const fs::path& p) { return fs::exists(p); });
  return {true, true, exists};
}

// ---- Paper citations ----

/// The tags of docs/papers.md: the bold first cell of each table row ("| **Khan et al.** | …").
std::set<std::string> paper_tags(const std::string& papers) {
  static const std::string kRow = "\n| **";
  std::set<std::string> found;
  for (std::size_t at = 0; (at = papers.find(kRow, at)) != std::string::npos; at += kRow.size()) {
    const std::size_t start = at + kRow.size();
    const std::size_t end = papers.find("**", start);
    if (end != std::string::npos) found.insert(papers.substr(start, end - start));
  }
  return found;
}

bool is_letter(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; }

/// Blanks and the comment marks a wrapped comment puts inside a tag ("Leng\n/// et al.").
bool is_gap(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '/' || c == '#' || c == '*'; }

/// The word that ends before `at`, across a gap.
std::string word_before(const std::string& text, std::size_t at) {
  std::size_t end = at;
  while (end > 0 && is_gap(text[end - 1])) --end;
  std::size_t start = end;
  while (start > 0 && is_letter(text[start - 1])) --start;
  return text.substr(start, end - start);
}

/// The word that starts after `at`, across a gap.
std::string word_after(const std::string& text, std::size_t at) {
  std::size_t start = at;
  while (start < text.size() && is_gap(text[start])) ++start;
  std::size_t end = start;
  while (end < text.size() && is_letter(text[end])) ++end;
  return text.substr(start, end - start);
}

bool is_name(const std::string& word) { return word.size() > 1 && is_upper(word[0]); }

/// Each author tag in `text`: "<Name> et al." and "<Name> & <Name>", however a comment's wrapping split it.
std::vector<std::string> author_tags(const std::string& text) {
  static const std::string kEtAl = "et al.";
  std::vector<std::string> found;
  for (std::size_t at = 0; (at = text.find(kEtAl, at)) != std::string::npos; at += kEtAl.size()) {
    if (at == 0 || !is_gap(text[at - 1])) continue;
    const std::string name = word_before(text, at);
    if (is_name(name)) found.push_back(name + " " + kEtAl);
  }
  for (std::size_t at = 0; (at = text.find('&', at)) != std::string::npos; ++at) {
    if (at == 0 || at + 1 >= text.size() || !is_gap(text[at - 1]) || !is_gap(text[at + 1])) continue;
    const std::string first = word_before(text, at);
    const std::string second = word_after(text, at + 1);
    if (is_name(first) && is_name(second)) found.push_back(first + " & " + second);
  }
  return found;
}

/// A paper cited the old ways: by the file name of a plain-text copy (a paper number, '_', 16 hex digits,
/// ".txt") or by its bare number before a locator (the number, then " eq.", " Alg.", " Table", …).
/// File and CLI names that hold a number ("reproduce_004.cpp", "dgbb-004-table1") and thousands
/// ("20 000") are not citations.
std::vector<std::string> untagged_papers(const std::string& text) {
  static const std::vector<std::string> kLocators{" eq.",   " eqs.",    " Alg.",       " Algorithm", " Sec.",
                                                  " Secs.", " Fig.",    " Figs.",      " Table",     " Thm.",
                                                  " Lemma", " Theorem", " as printed", "'s "};
  std::vector<std::string> found;
  for (std::size_t at = 0; (at = text.find("00", at)) != std::string::npos; ++at) {
    if (at + 3 > text.size() || text[at + 2] < '0' || text[at + 2] > '4') continue;
    const char before = at > 0 ? text[at - 1] : ' ';
    if (is_name_char(before) || before == '\'' || (at > 1 && is_digit(text[at - 2]) && !is_digit(before)))
      continue;
    std::size_t hex = at + 4;
    while (hex < text.size() && hex < at + 20 && std::isxdigit(static_cast<unsigned char>(text[hex])) != 0)
      ++hex;
    if (text.compare(at + 3, 1, "_") == 0 && hex == at + 20 && text.compare(hex, 4, ".txt") == 0) {
      found.push_back(text.substr(at, 24));
      continue;
    }
    for (const auto& locator : kLocators) {
      if (text.compare(at + 3, locator.size(), locator) == 0) found.push_back(text.substr(at, 3) + locator);
    }
  }
  return found;
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

/// A path from its names, so that the scan of this file does not read it as a citation.
std::string path_of(std::initializer_list<std::string_view> names) {
  std::string path;
  bool first = true;
  for (const auto name : names) {
    path += (first ? "" : "/") + std::string(name);
    first = false;
  }
  return path;
}

TEST(Citations, TheScannerReadsPathsAndPaperTags) {
  const std::string cited = "see " + path_of({"common", "world", "src", "world.cpp"}) + ", `" +
                            path_of({"runtime", "agent_loop.hpp"}) + "` and " + path_of({"scripts", "test"}) +
                            ". Not: https:" + path_of({"", "", "github.com", "a", "b.cpp"}) + " " +
                            path_of({"", "work", "x.cpp"}) + " " + path_of({"tests", "unit", "<lib>"}) + " " +
                            path_of({"agent", "agent_node.{hpp,cpp}"}) + "\n#include \"" +
                            path_of({"swarmloc", "core", "types.hpp"}) + "\"\n";
  EXPECT_EQ(path_tokens(cited),
            (std::vector<std::string>{path_of({"common", "world", "src", "world.cpp"}),
                                      path_of({"runtime", "agent_loop.hpp"}), path_of({"scripts", "test"})}));
  const auto libs = libraries();
  const fs::path here = kRoot / "docs" / "scale.md";
  const auto resolve = [&](std::initializer_list<std::string_view> names) {
    return resolve_cited_path(path_of(names), here, libs);
  };
  EXPECT_TRUE(resolve({"runtime", "agent_loop.hpp"}).exists);                 // include/swarmloc/runtime/
  EXPECT_TRUE(resolve({"sim", "agent_clock_simulator.cpp"}).exists);          // src/
  EXPECT_TRUE(resolve({"swarmloc", "world", "world.hpp"}).library_relative);  // an include path
  EXPECT_TRUE(resolve({"..", "bench", "scale.sh"}).exists);                   // relative to docs/
  EXPECT_TRUE(resolve({"common", "sim"}).exists);                             // a folder
  EXPECT_FALSE(
      resolve_cited_path(path_of({"..", "metrics.csv"}), kRoot / "common", libs).counted);  // code: run time
  EXPECT_TRUE(
      resolve_cited_path(path_of({"app", "main.cpp"}), kRoot / "research" / "CMakeLists.txt", libs).exists);
  const auto missing = resolve({"common", "world", "src", "nowhere.cpp"});
  EXPECT_TRUE(missing.counted);
  EXPECT_FALSE(missing.exists);
  EXPECT_FALSE(resolve({"world", "nowhere.cpp"}).exists);
  EXPECT_FALSE(resolve({"runs", "a", "summary.json"}).counted);  // a run directory, not the repository
  EXPECT_FALSE(resolve({"world", "agents"}).counted);            // no extension: prose, not a file
  EXPECT_FALSE(resolve({"agent", "fusion"}).counted);
  EXPECT_TRUE(resolve({"prog", "scale.py"}).counted);  // a script, wherever it starts
  EXPECT_FALSE(resolve({"prog", "scale.py"}).exists);

  const std::string et = " et", al = " al.", amp = " &";
  EXPECT_EQ(author_tags("(Khan" + et + al + " Alg. 3), Leng\n///" + et + al + "; Gasparri" + amp +
                        "\n// Pascucci; x" + amp + " y, a" + amp + "& b, Q" + amp + " A"),
            (std::vector<std::string>{"Khan" + et + al, "Leng" + et + al, "Gasparri" + amp + " Pascucci"}));
  const std::string zero = "00";
  EXPECT_EQ(untagged_papers(zero + "4 eq. (12), (" + zero + "1 Table II), " + zero + "3's BP, " + zero +
                            "0_3880facdfd67968a.txt; not: 20 " + zero + "0 Table, reproduce_" + zero +
                            "4.cpp, dgbb-" + zero + "4-table1"),
            (std::vector<std::string>{zero + "4 eq.", zero + "1 Table", zero + "3's ",
                                      zero + "0_3880facdfd67968a.txt"}));
  EXPECT_EQ(paper_tags("x\n| **Khan" + et + al + "** | A |\n| **Gasparri" + amp + " Pascucci** | B |\n"),
            (std::set<std::string>{"Khan" + et + al, "Gasparri" + amp + " Pascucci"}));
}

TEST(Citations, EveryCitedPathExistsInTheRepository) {
  const auto libs = libraries();
  int counted = 0, library_relative = 0;
  for (const auto& file : cited_texts()) {
    for (const auto& token : path_tokens(read_text(file))) {
      const auto cited = resolve_cited_path(token, file, libs);
      if (!cited.counted) continue;
      EXPECT_TRUE(cited.exists) << file.lexically_relative(kRoot).generic_string() << " cites " << token
                                << ", which is not in the repository";
      ++counted;
      if (cited.library_relative) ++library_relative;
    }
  }
  EXPECT_GT(counted, 300) << "the scan found too few cited paths to mean anything";
  EXPECT_GT(library_relative, 10);
  RecordProperty("paths", counted);
  RecordProperty("library_relative", library_relative);
}

TEST(Citations, EveryPaperIsCitedByATagOfThePapersPage) {
  const auto tags = paper_tags(read_text(kRoot / "docs/papers.md"));
  ASSERT_GE(tags.size(), 5U) << "docs/papers.md lists too few papers";
  int cited = 0;
  for (const auto& file : cited_texts()) {
    const std::string text = read_text(file);
    const std::string name = file.lexically_relative(kRoot).generic_string();
    for (const auto& tag : author_tags(text)) {
      EXPECT_TRUE(tags.contains(tag)) << name << " cites " << tag << ", which is not a tag of docs/papers.md";
      ++cited;
    }
    for (const auto& old : untagged_papers(text))
      ADD_FAILURE() << name << " cites a paper as \"" << old << "\": cite it by its tag in docs/papers.md";
  }
  EXPECT_GT(cited, 300) << "the scan found too few paper tags to mean anything";
  RecordProperty("paper_tags", cited);
}

TEST(Citations, TheDocsIndexListsEveryPage) {
  const std::string index = read_text(kRoot / "docs/README.md");
  int listed = 0;
  for (const auto& doc : documents()) {
    if (doc == "README.md") continue;
    EXPECT_NE(index.find("](" + doc + ")"), std::string::npos)
        << "docs/README.md does not list docs/" << doc << " (a line saying what it answers)";
    ++listed;
  }
  EXPECT_GT(listed, 30);
}

}  // namespace
