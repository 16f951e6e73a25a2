#include "silpose/io/camera_file.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_set>
#include <utility>
#include <vector>

#include "silpose/util/error.h"

// Camera files are read by silpose's own reader of the part of OpenCV's YAML, XML and JSON layouts
// that cv::FileStorage writes, not by OpenCV's parsers: those loop forever, crash or run out of
// memory on some malformed files. Each format's reader below turns the file into a small tree
// (Node), keeping the four camera keys and checking the syntax of everything else; one function
// then reads the camera from the tree. Every loop of the readers consumes input, the recursion is
// at most kMaxDepth deep, and a sequence keeps at most kMaxKeptItems items (it counts the others).

namespace silpose {
namespace {

constexpr int kMaxDepth = 64;
constexpr size_t kMaxKeptItems = 64;
constexpr long long kMaxMatrixElements = 16;

bool IsCameraKey(std::string_view key) {
  return key == "camera_matrix" || key == "distortion_coefficients" || key == "image_width" ||
         key == "image_height";
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsHexDigit(char c) { return IsDigit(c) || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'); }
bool IsLetter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool IsBlank(char c) { return c == ' ' || c == '\t'; }
bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\n'; }
bool IsOneOf(char c, std::string_view set) { return set.find(c) != std::string_view::npos; }

std::string_view TrimRight(std::string_view text) {
  while (!text.empty() && IsBlank(text.back())) text.remove_suffix(1);
  return text;
}

// A piece of the file quoted in a message: one line, printable ASCII, at most 40 characters.
std::string Quote(std::string_view text) {
  constexpr size_t kMax = 40;
  std::string quoted = "'";
  for (size_t i = 0; i < text.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    quoted += c < 0x20 || c >= 0x7f ? '?' : static_cast<char>(c);
  }
  if (text.size() > kMax) quoted += "...";
  return quoted + "'";
}

// ---------------------------------------------------------------------------------------------
// Numbers: what OpenCV writes ("525.", "-2.0000000000000001e-01", "0.0", "7", ".Nan", "-.Inf").

enum class NumberKind { kFinite, kNotFinite, kOutOfRange, kInvalid };

NumberKind ParseNumber(std::string_view text, double* value) {
  bool negative = false;
  if (!text.empty() && (text[0] == '+' || text[0] == '-')) {
    negative = text[0] == '-';
    text.remove_prefix(1);
  }
  auto lower_equals = [&](std::string_view word) {
    if (text.size() != word.size()) return false;
    for (size_t i = 0; i < text.size(); ++i) {
      const char c = text[i] >= 'A' && text[i] <= 'Z' ? static_cast<char>(text[i] + 32) : text[i];
      if (c != word[i]) return false;
    }
    return true;
  };
  if (lower_equals(".nan")) {
    *value = std::numeric_limits<double>::quiet_NaN();
    return NumberKind::kNotFinite;
  }
  if (lower_equals(".inf")) {
    *value = negative ? -std::numeric_limits<double>::infinity()
                      : std::numeric_limits<double>::infinity();
    return NumberKind::kNotFinite;
  }
  size_t i = 0;
  size_t digits = 0;
  while (i < text.size() && IsDigit(text[i])) ++i, ++digits;
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && IsDigit(text[i])) ++i, ++digits;
  }
  if (digits == 0) return NumberKind::kInvalid;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    const size_t exponent_start = i;
    while (i < text.size() && IsDigit(text[i])) ++i;
    if (i == exponent_start) return NumberKind::kInvalid;
  }
  if (i != text.size()) return NumberKind::kInvalid;
  double parsed = 0.0;
  const auto result = std::from_chars(text.data(), text.data() + text.size(), parsed);
  if (result.ec == std::errc::result_out_of_range) return NumberKind::kOutOfRange;
  if (result.ec != std::errc() || result.ptr != text.data() + text.size()) {
    return NumberKind::kInvalid;
  }
  *value = negative ? -parsed : parsed;
  return NumberKind::kFinite;
}

// A whole number: [+-]digits. False if it is not one; *out_of_range if it does not fit.
bool ParseInteger(std::string_view text, long long* value, bool* out_of_range) {
  *out_of_range = false;
  bool negative = false;
  if (!text.empty() && (text[0] == '+' || text[0] == '-')) {
    negative = text[0] == '-';
    text.remove_prefix(1);
  }
  if (text.empty()) return false;
  for (char c : text) {
    if (!IsDigit(c)) return false;
  }
  unsigned long long magnitude = 0;
  const auto result = std::from_chars(text.data(), text.data() + text.size(), magnitude);
  if (result.ec != std::errc() ||
      magnitude > static_cast<unsigned long long>(std::numeric_limits<long long>::max())) {
    *out_of_range = true;
    return true;
  }
  *value = negative ? -static_cast<long long>(magnitude) : static_cast<long long>(magnitude);
  return true;
}

// ---------------------------------------------------------------------------------------------
// The tree the readers make.

struct Member;

struct Node {
  enum class Kind {
    kEmpty,     // no value ("key:" in YAML, <key/> or <key></key> in XML)
    kScalar,    // an unquoted value: a number, a word (JSON: a number)
    kString,    // a quoted string
    kSequence,  // [ ... ], "- " items, several values of an XML element, <_> elements
    kMap,       // keys and values
    kBinary,    // base64 data (YAML !!binary, XML type_id="binary", JSON "$base64$...")
  };
  Kind kind = Kind::kEmpty;
  int line = 0;
  std::string text;             // kScalar, kString
  std::string tag;              // YAML's !!tag, XML's type_id attribute
  std::vector<Node> items;      // kSequence: the first kMaxKeptItems items
  size_t count = 0;             // kSequence: the number of items
  std::vector<Member> members;  // kMap: the keys kept (at the top level, the camera keys only)
};

struct Member {
  std::string key;
  int line = 0;
  Node value;
};

void AddItem(Node* sequence, Node&& item) {
  if (sequence == nullptr) return;
  if (sequence->count < kMaxKeptItems) sequence->items.push_back(std::move(item));
  ++sequence->count;
}

// Where the next item of `sequence` is parsed to: nowhere once enough are kept.
Node* ItemTarget(Node* sequence, Node* item) {
  return sequence != nullptr && sequence->count < kMaxKeptItems ? item : nullptr;
}

// Whether the value of `key` in a map at `depth` (the top level is 1) is kept: the top level keeps
// the camera keys, below them everything is kept.
bool KeepValue(const Node* map, int depth, std::string_view key) {
  return map != nullptr && (depth > 1 || IsCameraKey(key));
}

// What the readers share: the text, the position, the line, the file's name for messages.
class Cursor {
 public:
  Cursor(std::string_view text, const std::string& name) : text_(text), name_(name) {}

 protected:
  bool AtEnd(size_t ahead = 0) const { return p_ + ahead >= text_.size(); }
  char Peek(size_t ahead = 0) const { return AtEnd(ahead) ? '\0' : text_[p_ + ahead]; }
  bool StartsWith(std::string_view prefix) const {
    return text_.substr(p_).substr(0, prefix.size()) == prefix;
  }
  void Advance() {
    if (text_[p_] == '\n') ++line_;
    ++p_;
  }
  // Moves to `position` (not before the current one), counting the lines passed.
  void AdvanceTo(size_t position) {
    for (; p_ < position; ++p_) {
      if (text_[p_] == '\n') ++line_;
    }
  }
  // The character at the position, for messages.
  std::string Describe() const {
    if (AtEnd()) return "the end of the file";
    if (Peek() == '\n') return "the end of the line";
    return Quote(text_.substr(p_, 1));
  }
  template <typename... Parts>
  [[noreturn]] void Fail(int line, const Parts&... parts) const {
    ThrowError(name_, ": line ", line, ": ", parts...);
  }
  void CheckDepth(int depth) const {
    if (depth > kMaxDepth) Fail(line_, "values nested more than ", kMaxDepth, " levels deep");
  }
  // A key seen twice in a map that is kept.
  void CheckNewKey(std::unordered_set<std::string>* keys, const Node* map, const std::string& key,
                   int line) const {
    if (map != nullptr && !keys->insert(key).second) {
      Fail(line, "the key ", Quote(key), " appears twice");
    }
  }

  std::string_view text_;
  size_t p_ = 0;
  int line_ = 1;
  const std::string& name_;
};

// ---------------------------------------------------------------------------------------------
// YAML as cv::FileStorage writes it: a "%YAML:1.0" line, an optional "---", then a block map of
// "key: value" lines; values are scalars, quoted strings, [ ... ] and { ... } (which may span
// lines), nested block maps and "- " sequences indented further, "!!tag"s (!!opencv-matrix) and
// "!!binary |" blocks; "#" comments. Not YAML's anchors, aliases, multi-line plain scalars, or
// more than one document.

class YamlReader : Cursor {
 public:
  using Cursor::Cursor;

  Node Read() {
    if (!StartsWith("%YAML") || (Peek(5) != ':' && Peek(5) != ' ') || Peek(6) != '1' ||
        Peek(7) != '.' || !IsDigit(Peek(8))) {
      Fail(1, "a YAML camera file must begin with %YAML:1.0");
    }
    p_ += 9;
    while (IsDigit(Peek())) ++p_;
    ExpectLineEnd("%YAML:1.0");
    if (NextContentLine() == 0 && AtDocumentMarker("---")) {
      p_ += 3;
      ExpectLineEnd("---");
    }
    Node root;
    root.line = line_;
    ParseBlockMap(0, &root, 1);
    if (NextContentLine() >= 0) {  // ParseBlockMap(0) stops at the end or at --- or ...
      const int marker_line = line_;
      if (AtDocumentMarker("...")) {
        p_ += 3;
        ExpectLineEnd("...");
        if (NextContentLine() < 0) return root;
        Fail(line_, "text after the end of the YAML document (...)");
      }
      Fail(marker_line, "a second YAML document (---); a camera file holds one");
    }
    return root;
  }

 private:
  bool AtDocumentMarker(std::string_view marker) const {
    return StartsWith(marker) && (AtEnd(3) || IsSpace(Peek(3)));
  }
  bool SpaceOrEndAt(size_t ahead) const { return AtEnd(ahead) || IsSpace(Peek(ahead)); }
  // A '#' at the position starts a comment: at the start of a line or after a space.
  bool AtComment() const { return Peek() == '#' && (p_ == 0 || IsSpace(text_[p_ - 1])); }
  void SkipBlanks() {
    while (IsBlank(Peek())) ++p_;
  }
  // Blanks and a comment, up to (not including) the end of the line.
  void SkipBlanksAndComment() {
    SkipBlanks();
    if (AtComment()) {
      while (!AtEnd() && Peek() != '\n') ++p_;
    }
  }
  // The rest of the line must be blank or a comment; consumes the line feed.
  void ExpectLineEnd(std::string_view after) {
    SkipBlanksAndComment();
    if (AtEnd()) return;
    if (Peek() != '\n') Fail(line_, "unexpected ", Describe(), " after ", after);
    Advance();
  }

  // Skips blank and comment lines. Returns the indentation of the next line with content (the
  // position stays at its start), or -1 at the end of the file.
  int NextContentLine() {
    if (p_ == peeked_position_) return peeked_indent_;
    while (!AtEnd()) {
      size_t q = p_;
      while (q < text_.size() && text_[q] == ' ') ++q;
      size_t r = q;
      while (r < text_.size() && IsBlank(text_[r])) ++r;
      if (r == text_.size()) {
        p_ = r;
        break;
      }
      if (text_[r] == '\n' || text_[r] == '#') {
        const size_t end = text_.find('\n', r);
        if (end == std::string_view::npos) {
          p_ = text_.size();
          break;
        }
        p_ = end + 1;
        ++line_;
        continue;
      }
      if (r != q) Fail(line_, "a tab in the indentation");
      peeked_position_ = p_;
      peeked_indent_ = static_cast<int>(q - p_);
      return peeked_indent_;
    }
    return -1;
  }

  // A block map whose keys are indented by `indent`; the position is at the start of a line.
  void ParseBlockMap(int indent, Node* out, int depth) {
    CheckDepth(depth);
    if (out != nullptr) out->kind = Node::Kind::kMap;
    std::unordered_set<std::string> keys;
    for (int next; (next = NextContentLine()) >= indent;) {
      if (next > indent) {
        Fail(line_, "unexpected indentation (", next, " spaces where the keys have ", indent, ")");
      }
      if (indent == 0 && (AtDocumentMarker("---") || AtDocumentMarker("..."))) return;
      p_ += static_cast<size_t>(indent);
      Member member{ParseKey(), line_, {}};
      CheckNewKey(&keys, out, member.key, member.line);
      const bool keep = KeepValue(out, depth, member.key);
      ParseBlockValue(indent, keep ? &member.value : nullptr, depth + 1);
      if (keep) out->members.push_back(std::move(member));
    }
  }

  // A block sequence whose "- " are indented by `indent`; the position is at the start of a line.
  void ParseBlockSequence(int indent, Node* out, int depth) {
    CheckDepth(depth);
    if (out != nullptr) out->kind = Node::Kind::kSequence;
    for (int next; (next = NextContentLine()) >= indent;) {
      if (next > indent) {
        Fail(line_, "unexpected indentation (", next, " spaces where the items have ", indent, ")");
      }
      p_ += static_cast<size_t>(indent);
      if (Peek() != '-' || !SpaceOrEndAt(1)) {
        Fail(line_, "expected a sequence item (- ), found ", Describe());
      }
      ++p_;
      Node item;
      ParseBlockValue(indent, ItemTarget(out, &item), depth + 1);
      AddItem(out, std::move(item));
    }
  }

  // "key" up to and including its ':' (followed by a blank or the end of the line).
  std::string ParseKey() {
    const char c = Peek();
    if (c == '"' || c == '\'') {
      std::string key;
      ParseQuoted(&key);
      if (Peek() != ':' || !SpaceOrEndAt(1)) Fail(line_, "expected ': ' after the key");
      ++p_;
      return key;
    }
    if (c == '-' && SpaceOrEndAt(1)) Fail(line_, "a sequence item (- ) where a key was expected");
    if (IsOneOf(c, "?:,[]{}#&*!|>%@`") && !(IsOneOf(c, "?:") && !SpaceOrEndAt(1))) {
      Fail(line_, "expected 'key: value', found ", Describe());
    }
    const size_t start = p_;
    while (!(Peek() == ':' && SpaceOrEndAt(1))) {
      if (AtEnd() || Peek() == '\n' || AtComment()) {
        Fail(line_, "expected 'key: value', found ", Quote(text_.substr(start, p_ - start)));
      }
      ++p_;
    }
    const std::string key(TrimRight(text_.substr(start, p_ - start)));
    ++p_;
    return key;
  }

  // The value after "key:" or "- ": on the rest of the line, or below it, indented further than
  // `indent`. Ends at the start of the next line.
  void ParseBlockValue(int indent, Node* out, int depth) {
    CheckDepth(depth);
    SkipBlanks();
    std::string tag;
    if (Peek() == '!') {
      tag = ParseTag();
      SkipBlanks();
    }
    if (out != nullptr) out->line = line_;
    const char c = Peek();
    if (AtEnd() || c == '\n' || AtComment()) {
      ExpectLineEnd("the key");
      const int next = NextContentLine();
      if (next > indent) {
        const char first = text_[p_ + static_cast<size_t>(next)];
        if (first == '-' && (p_ + next + 1 >= text_.size() || IsSpace(text_[p_ + next + 1]))) {
          ParseBlockSequence(next, out, depth);
        } else if (first == '[' || first == '{') {
          p_ += static_cast<size_t>(next);
          ParseFlow(out, depth);
          ExpectLineEnd(first == '[' ? "]" : "}");
        } else {
          ParseBlockMap(next, out, depth);
        }
      } else if (out != nullptr) {
        out->kind = Node::Kind::kEmpty;
      }
    } else if (c == '[' || c == '{') {
      ParseFlow(out, depth);
      ExpectLineEnd(c == '[' ? "]" : "}");
    } else if (c == '|' || c == '>') {
      SkipBlockScalar(indent);
      if (out != nullptr) out->kind = tag == "binary" ? Node::Kind::kBinary : Node::Kind::kString;
    } else if (c == '"' || c == '\'') {
      ParseQuoted(out != nullptr ? &out->text : nullptr);
      if (out != nullptr) out->kind = Node::Kind::kString;
      ExpectLineEnd("the string");
    } else if (c == '&' || c == '*') {
      Fail(line_, "anchors and aliases (& and *) are not supported");
    } else if (c == '-' && SpaceOrEndAt(1)) {
      Fail(line_, "a sequence item (- ) must begin its own line");
    } else if (IsOneOf(c, ",]}%@`")) {
      Fail(line_, "unexpected ", Describe());
    } else {
      const size_t start = p_;
      while (!AtEnd() && Peek() != '\n' && !AtComment()) ++p_;
      if (out != nullptr) {
        out->kind = Node::Kind::kScalar;
        out->text = std::string(TrimRight(text_.substr(start, p_ - start)));
      }
      ExpectLineEnd("the value");
    }
    if (out != nullptr && !tag.empty()) out->tag = tag;
  }

  // "!!name" or "!name": the name.
  std::string ParseTag() {
    const int tag_line = line_;
    const size_t start = p_;
    while (!AtEnd() && !IsSpace(Peek()) && !IsOneOf(Peek(), ",[]{}")) ++p_;
    std::string_view tag = text_.substr(start, p_ - start);
    tag.remove_prefix(tag.size() > 1 && tag[1] == '!' ? 2 : 1);
    if (tag.empty()) Fail(tag_line, "a tag (!) without a name");
    return std::string(tag);
  }

  // "|" or ">" and the lines below it indented further than `indent` (blank lines too).
  void SkipBlockScalar(int indent) {
    ++p_;
    while (IsOneOf(Peek(), "+-0123456789")) ++p_;
    ExpectLineEnd("the block scalar indicator");
    while (!AtEnd()) {
      size_t q = p_;
      while (q < text_.size() && text_[q] == ' ') ++q;
      const bool blank = q == text_.size() || text_[q] == '\n';
      if (!blank && q - p_ <= static_cast<size_t>(indent)) break;
      const size_t end = text_.find('\n', q);
      if (end == std::string_view::npos) {
        p_ = text_.size();
        break;
      }
      p_ = end + 1;
      ++line_;
    }
  }

  // A string in double quotes (with backslash escapes) or single quotes ('' is a quote), on one
  // line. Its characters go to *text unless text is null.
  void ParseQuoted(std::string* text) {
    const char quote = Peek();
    ++p_;
    while (true) {
      if (AtEnd() || Peek() == '\n') Fail(line_, "a quoted string that does not end on its line");
      const char c = text_[p_++];
      if (c == quote) {
        if (quote == '\'' && Peek() == '\'') {
          ++p_;
          if (text != nullptr) *text += '\'';
          continue;
        }
        return;
      }
      char decoded = c;
      if (c == '\\' && quote == '"') {
        if (AtEnd() || Peek() == '\n') Fail(line_, "a quoted string that does not end on its line");
        const char escape = text_[p_++];
        decoded = escape;
        if (escape == 'n') decoded = '\n';
        if (escape == 't') decoded = '\t';
        if (escape == 'r') decoded = '\r';
        if (escape == 'x') {
          if (!IsHexDigit(Peek()) || !IsHexDigit(Peek(1))) {
            Fail(line_, "a \\x escape without two hexadecimal digits");
          }
          decoded = static_cast<char>(std::stoi(std::string(text_.substr(p_, 2)), nullptr, 16));
          p_ += 2;
        }
      }
      if (text != nullptr) *text += decoded;
    }
  }

  // Blanks, line feeds and comments inside [ ] and { }.
  void SkipFlowSpace() {
    while (!AtEnd()) {
      if (IsSpace(Peek())) {
        Advance();
      } else if (AtComment()) {
        while (!AtEnd() && Peek() != '\n') ++p_;
      } else {
        break;
      }
    }
  }

  // [ value, ... ] or { key: value, ... } (OpenCV writes "key:value" there), over any lines.
  void ParseFlow(Node* out, int depth) {
    CheckDepth(depth);
    const bool is_map = Peek() == '{';
    const char close = is_map ? '}' : ']';
    const int open_line = line_;
    ++p_;
    if (out != nullptr) {
      out->kind = is_map ? Node::Kind::kMap : Node::Kind::kSequence;
      out->line = open_line;
    }
    std::unordered_set<std::string> keys;
    SkipFlowSpace();
    if (Peek() == close) {
      ++p_;
      return;
    }
    while (true) {
      if (AtEnd()) Fail(open_line, "a '", is_map ? '{' : '[', "' that is never closed");
      if (is_map) {
        Member member;
        member.line = line_;
        member.key = ParseFlowKey();
        CheckNewKey(&keys, out, member.key, member.line);
        ParseFlowValue(out != nullptr ? &member.value : nullptr, depth + 1);
        if (out != nullptr) out->members.push_back(std::move(member));
      } else {
        Node item;
        ParseFlowValue(ItemTarget(out, &item), depth + 1);
        AddItem(out, std::move(item));
      }
      SkipFlowSpace();
      if (AtEnd()) Fail(open_line, "a '", is_map ? '{' : '[', "' that is never closed");
      if (Peek() == close) {
        ++p_;
        return;
      }
      if (Peek() != ',') Fail(line_, "expected ',' or '", close, "', found ", Describe());
      ++p_;
      SkipFlowSpace();
      if (Peek() == close) {  // a trailing comma
        ++p_;
        return;
      }
    }
  }

  std::string ParseFlowKey() {
    SkipFlowSpace();
    std::string key;
    if (Peek() == '"' || Peek() == '\'') {
      ParseQuoted(&key);
    } else {
      const size_t start = p_;
      while (!AtEnd() && !IsOneOf(Peek(), ":,[]{}\n#")) ++p_;
      key = std::string(TrimRight(text_.substr(start, p_ - start)));
      if (key.empty()) Fail(line_, "expected 'key: value' in { }, found ", Describe());
    }
    SkipBlanks();
    if (Peek() != ':') Fail(line_, "expected ':' after the key ", Quote(key), " in { }");
    ++p_;
    return key;
  }

  void ParseFlowValue(Node* out, int depth) {
    CheckDepth(depth);
    SkipFlowSpace();
    std::string tag;
    if (Peek() == '!') {
      tag = ParseTag();
      SkipFlowSpace();
    }
    if (out != nullptr) out->line = line_;
    const char c = Peek();
    if (c == '[' || c == '{') {
      ParseFlow(out, depth);
    } else if (c == '"' || c == '\'') {
      ParseQuoted(out != nullptr ? &out->text : nullptr);
      if (out != nullptr) out->kind = Node::Kind::kString;
    } else if (c == '&' || c == '*') {
      Fail(line_, "anchors and aliases (& and *) are not supported");
    } else if (AtEnd() || IsOneOf(c, ",]}:")) {
      Fail(line_, "expected a value, found ", Describe());
    } else {
      const size_t start = p_;
      while (!AtEnd() && !IsOneOf(Peek(), ",[]{}\n") && !AtComment()) ++p_;
      if (out != nullptr) {
        out->kind = Node::Kind::kScalar;
        out->text = std::string(TrimRight(text_.substr(start, p_ - start)));
      }
    }
    if (out != nullptr && !tag.empty()) out->tag = tag;
  }

  size_t peeked_position_ = std::string_view::npos;
  int peeked_indent_ = -1;
};

// ---------------------------------------------------------------------------------------------
// XML as cv::FileStorage writes it: "<?xml ...?>", then <opencv_storage> holding one element per
// key; an element holds child elements (a map; <_> children are a sequence's items) or
// whitespace-separated values ("quoted" strings); type_id="..." attributes; <!-- comments -->;
// the entities &lt; &gt; &amp; &apos; &quot; &#N; &#xN;. Not CDATA, DOCTYPE or processing
// instructions.

class XmlReader : Cursor {
 public:
  using Cursor::Cursor;

  Node Read() {
    SkipSpace();
    if (!StartsWith("<?xml")) Fail(line_, "an XML camera file must begin with <?xml ...?>");
    const size_t end = text_.find("?>", p_);
    if (end == std::string_view::npos) Fail(line_, "the <?xml declaration is never closed");
    AdvanceTo(end + 2);
    SkipSpaceAndComments();
    if (Peek() != '<') Fail(line_, "expected <opencv_storage>, found ", Describe());
    const int root_line = line_;
    ++p_;
    const std::string name = ParseName();
    if (name != "opencv_storage") {
      Fail(root_line, "the root element must be <opencv_storage>, not ",
           Quote(name.empty() ? text_.substr(p_, 1) : name));
    }
    Node root;
    ParseElement(name, root_line, &root, 1);
    SkipSpaceAndComments();
    if (!AtEnd()) Fail(line_, "unexpected ", Describe(), " after </opencv_storage>");
    return root;
  }

 private:
  static bool IsNameChar(char c) { return IsLetter(c) || IsDigit(c) || IsOneOf(c, "_-.:"); }

  void SkipSpace() {
    while (IsSpace(Peek())) Advance();
  }
  void SkipComment() {
    const int start_line = line_;
    const size_t end = text_.find("-->", p_ + 4);
    if (end == std::string_view::npos) Fail(start_line, "a comment (<!--) that is never closed");
    AdvanceTo(end + 3);
  }
  void SkipSpaceAndComments() {
    while (true) {
      SkipSpace();
      if (!StartsWith("<!--")) return;
      SkipComment();
    }
  }
  std::string ParseName() {
    const size_t start = p_;
    while (IsNameChar(Peek())) ++p_;
    return std::string(text_.substr(start, p_ - start));
  }

  // "&...;": checks it is an entity; appends it, undecoded, to *raw unless raw is null.
  void ParseEntity(std::string* raw) {
    size_t end = p_ + 1;
    while (end < text_.size() && end - p_ < 12 &&
           (IsLetter(text_[end]) || IsDigit(text_[end]) || text_[end] == '#')) {
      ++end;
    }
    if (end >= text_.size() || text_[end] != ';') {
      Fail(line_, "a '&' that does not begin an entity (&lt; &gt; &amp; &apos; &quot;)");
    }
    const std::string_view body = text_.substr(p_ + 1, end - p_ - 1);
    bool valid = body == "lt" || body == "gt" || body == "amp" || body == "apos" || body == "quot";
    if (body.size() >= 2 && body[0] == '#') {
      const bool hex = body[1] == 'x';
      const std::string_view digits = body.substr(hex ? 2 : 1);
      valid = !digits.empty() && digits.size() <= 6;
      for (char c : digits) valid = valid && (hex ? IsHexDigit(c) : IsDigit(c));
    }
    if (!valid) Fail(line_, "an unknown entity ", Quote(text_.substr(p_, end + 1 - p_)));
    if (raw != nullptr) raw->append(text_.substr(p_, end + 1 - p_));
    p_ = end + 1;
  }

  // The element <name ...> whose name has just been read, up to and including </name>.
  void ParseElement(const std::string& name, int open_line, Node* out, int depth) {
    CheckDepth(depth);
    if (out != nullptr) out->line = open_line;
    std::string tag;
    while (true) {  // attributes
      const bool spaced = IsSpace(Peek());
      SkipSpace();
      if (AtEnd()) Fail(open_line, "the tag <", name, " is never closed");
      if (Peek() == '>') {
        ++p_;
        break;
      }
      if (Peek() == '/' && Peek(1) == '>') {
        p_ += 2;
        if (out != nullptr) {
          out->kind = tag == "binary" ? Node::Kind::kBinary : Node::Kind::kEmpty;
          out->tag = tag;
        }
        return;
      }
      const std::string attribute = ParseName();
      if (!spaced || attribute.empty()) {
        Fail(line_, "unexpected ", Describe(), " in the tag <", name, ">");
      }
      SkipSpace();
      if (Peek() != '=') Fail(line_, "expected '=' after the attribute ", attribute);
      ++p_;
      SkipSpace();
      const char quote = Peek();
      if (quote != '"' && quote != '\'') {
        Fail(line_, "expected a quoted value of the attribute ", attribute);
      }
      const size_t end = text_.find(quote, p_ + 1);
      if (end == std::string_view::npos) Fail(line_, "the value of ", attribute, " never ends");
      const std::string_view value = text_.substr(p_ + 1, end - p_ - 1);
      if (value.find('<') != std::string_view::npos) Fail(line_, "a '<' in an attribute value");
      if (attribute == "type_id") tag = std::string(value);
      AdvanceTo(end + 1);
    }
    std::string raw;  // the text between the child elements (if kept), entities not decoded
    bool has_text = false;
    bool has_members = false;
    Node items;  // the <_> children
    items.kind = Node::Kind::kSequence;
    std::unordered_set<std::string> keys;
    while (true) {
      if (AtEnd()) Fail(open_line, "<", name, "> is never closed");
      const char c = Peek();
      if (c == '&') {
        ParseEntity(out != nullptr ? &raw : nullptr);
        has_text = true;
        continue;
      }
      if (c != '<') {
        if (!IsSpace(c)) has_text = true;
        if (out != nullptr) raw += c;
        Advance();
        continue;
      }
      if (StartsWith("</")) {
        const int close_line = line_;
        p_ += 2;
        const std::string closing = ParseName();
        SkipSpace();
        if (Peek() != '>') Fail(line_, "expected '>' after </", closing);
        ++p_;
        if (closing != name) {
          Fail(close_line, "</", closing, "> where </", name, "> (opened on line ", open_line,
               ") was expected");
        }
        break;
      }
      if (StartsWith("<!--")) {
        SkipComment();
        continue;
      }
      if (StartsWith("<!") || StartsWith("<?")) {
        Fail(line_, "CDATA sections, DOCTYPE and processing instructions are not supported");
      }
      const int child_line = line_;
      ++p_;
      Member member{ParseName(), child_line, {}};
      if (member.key.empty()) Fail(line_, "expected an element name after '<', found ", Describe());
      if (member.key == "_") {
        Node item;
        Node* kept_items = out != nullptr ? &items : nullptr;
        ParseElement(member.key, child_line, ItemTarget(kept_items, &item), depth + 1);
        AddItem(kept_items, std::move(item));
        continue;
      }
      CheckNewKey(&keys, out, member.key, child_line);
      const bool keep = KeepValue(out, depth, member.key);
      ParseElement(member.key, child_line, keep ? &member.value : nullptr, depth + 1);
      if (keep) out->members.push_back(std::move(member));
      has_members = true;
    }
    if (out == nullptr) return;
    if (has_members) {
      if (has_text || items.count > 0) Fail(open_line, "<", name, "> mixes keys and values");
      out->kind = Node::Kind::kMap;
    } else if (items.count > 0) {
      if (has_text) Fail(open_line, "<", name, "> mixes <_> items and values");
      out->kind = Node::Kind::kSequence;
      out->items = std::move(items.items);
      out->count = items.count;
    } else {
      ParseValues(raw, open_line, out);
    }
    out->tag = tag;
    if (tag == "binary") out->kind = Node::Kind::kBinary;
  }

  // The text of an element: whitespace-separated values, "strings" in quotes. None is kEmpty, one
  // a scalar or string, more a sequence.
  void ParseValues(std::string_view raw, int line, Node* out) const {
    Node values;
    values.kind = Node::Kind::kSequence;
    size_t i = 0;
    while (i < raw.size()) {
      if (IsSpace(raw[i])) {
        ++i;
        continue;
      }
      Node value;
      value.line = line;
      size_t end = i;
      if (raw[i] == '"') {
        end = raw.find('"', i + 1);
        if (end == std::string_view::npos) Fail(line, "a quoted string that is never closed");
        value.kind = Node::Kind::kString;
        value.text = DecodeEntities(raw.substr(i + 1, end - i - 1));
        ++end;
        if (end < raw.size() && !IsSpace(raw[end])) {
          Fail(line, "unexpected ", Quote(raw.substr(end, 1)), " after a quoted string");
        }
      } else {
        while (end < raw.size() && !IsSpace(raw[end])) ++end;
        value.kind = Node::Kind::kScalar;
        value.text = DecodeEntities(raw.substr(i, end - i));
      }
      i = end;
      AddItem(&values, std::move(value));
    }
    if (values.count == 0) {
      out->kind = Node::Kind::kEmpty;
    } else if (values.count == 1) {
      out->kind = values.items[0].kind;
      out->text = std::move(values.items[0].text);
    } else {
      out->kind = Node::Kind::kSequence;
      out->items = std::move(values.items);
      out->count = values.count;
    }
  }

  // Entities were checked by ParseEntity; a character beyond ASCII becomes '?' (only numbers and
  // the element type are read from the values).
  static std::string DecodeEntities(std::string_view text) {
    std::string decoded;
    for (size_t i = 0; i < text.size(); ++i) {
      if (text[i] != '&') {
        decoded += text[i];
        continue;
      }
      const size_t end = text.find(';', i);
      const std::string_view body = text.substr(i + 1, end - i - 1);
      i = end;
      if (body == "lt") {
        decoded += '<';
      } else if (body == "gt") {
        decoded += '>';
      } else if (body == "amp") {
        decoded += '&';
      } else if (body == "apos") {
        decoded += '\'';
      } else if (body == "quot") {
        decoded += '"';
      } else {
        const bool hex = body[1] == 'x';
        const std::string_view digits = body.substr(hex ? 2 : 1);
        unsigned code = 0;
        std::from_chars(digits.data(), digits.data() + digits.size(), code, hex ? 16 : 10);
        decoded += code > 0 && code < 0x80 ? static_cast<char>(code) : '?';
      }
    }
    return decoded;
  }
};

// ---------------------------------------------------------------------------------------------
// JSON as cv::FileStorage writes it: an object of keys; values are numbers (also .Nan, .Inf,
// -.Inf; not true, false or null), strings (with JSON's escapes and OpenCV's \' and \xHH), arrays
// and objects; "type_id" is a key; "// comments" (OpenCV writes them on their own lines, even
// before a comma); base64 data is a string "$base64$...".

class JsonReader : Cursor {
 public:
  using Cursor::Cursor;

  Node Read() {
    SkipSpace();
    if (Peek() != '{') Fail(line_, "a JSON camera file must be an object ({ ... })");
    Node root;
    ParseValue(&root, 1);
    SkipSpace();
    if (!AtEnd()) Fail(line_, "unexpected ", Describe(), " after the end of the JSON object");
    return root;
  }

 private:
  void SkipSpace() {
    while (!AtEnd()) {
      if (IsSpace(Peek())) {
        Advance();
      } else if (Peek() == '/' && Peek(1) == '/') {
        while (!AtEnd() && Peek() != '\n') ++p_;
      } else {
        break;
      }
    }
  }

  void ParseValue(Node* out, int depth) {
    CheckDepth(depth);
    SkipSpace();
    if (out != nullptr) out->line = line_;
    const char c = Peek();
    if (c == '{') {
      ParseObject(out, depth);
    } else if (c == '[') {
      ParseArray(out, depth);
    } else if (c == '"') {
      std::string text;
      ParseString(out != nullptr ? &text : nullptr);
      if (out != nullptr) {
        const bool binary = text.rfind("$base64$", 0) == 0;
        out->kind = binary ? Node::Kind::kBinary : Node::Kind::kString;
        out->text = std::move(text);
      }
    } else {
      const size_t start = p_;
      while (!AtEnd() && (IsLetter(Peek()) || IsDigit(Peek()) || IsOneOf(Peek(), ".+-"))) ++p_;
      const std::string_view literal = text_.substr(start, p_ - start);
      if (literal.empty()) Fail(line_, "expected a value, found ", Describe());
      double number = 0.0;
      if (ParseNumber(literal, &number) == NumberKind::kInvalid) {  // OpenCV has no true, null
        Fail(line_, Quote(literal), " is not a number, string, list or map");
      }
      if (out != nullptr) {
        out->kind = Node::Kind::kScalar;
        out->text = std::string(literal);
      }
    }
  }

  void ParseObject(Node* out, int depth) {
    const int open_line = line_;
    ++p_;
    if (out != nullptr) out->kind = Node::Kind::kMap;
    std::unordered_set<std::string> keys;
    SkipSpace();
    if (Peek() == '}') {
      ++p_;
      return;
    }
    while (true) {
      SkipSpace();
      if (AtEnd()) Fail(open_line, "a '{' that is never closed");
      if (Peek() != '"') Fail(line_, "expected a key in double quotes, found ", Describe());
      Member member;
      member.line = line_;
      ParseString(&member.key);
      SkipSpace();
      if (Peek() != ':') Fail(line_, "expected ':' after the key ", Quote(member.key));
      ++p_;
      CheckNewKey(&keys, out, member.key, member.line);
      const bool keep = KeepValue(out, depth, member.key);
      ParseValue(keep ? &member.value : nullptr, depth + 1);
      if (keep) out->members.push_back(std::move(member));
      SkipSpace();
      if (AtEnd()) Fail(open_line, "a '{' that is never closed");
      if (Peek() == '}') {
        ++p_;
        return;
      }
      if (Peek() != ',') Fail(line_, "expected ',' or '}', found ", Describe());
      ++p_;
    }
  }

  void ParseArray(Node* out, int depth) {
    const int open_line = line_;
    ++p_;
    if (out != nullptr) out->kind = Node::Kind::kSequence;
    SkipSpace();
    if (Peek() == ']') {
      ++p_;
      return;
    }
    while (true) {
      Node item;
      ParseValue(ItemTarget(out, &item), depth + 1);
      AddItem(out, std::move(item));
      SkipSpace();
      if (AtEnd()) Fail(open_line, "a '[' that is never closed");
      if (Peek() == ']') {
        ++p_;
        return;
      }
      if (Peek() != ',') Fail(line_, "expected ',' or ']', found ", Describe());
      ++p_;
    }
  }

  // A string in double quotes, on one line; its characters go to *text unless text is null.
  void ParseString(std::string* text) {
    ++p_;
    while (true) {
      if (AtEnd() || Peek() == '\n') Fail(line_, "a string that does not end on its line");
      const char c = text_[p_++];
      if (c == '"') return;
      char decoded = c;
      if (c == '\\') {
        if (AtEnd()) Fail(line_, "a string that does not end on its line");
        const char escape = Peek();
        ++p_;
        switch (escape) {
          case '"':
          case '\\':
          case '/':
          case '\'':  // OpenCV escapes ' too
            decoded = escape;
            break;
          case 'x':  // and other bytes as \xHH
            if (!IsHexDigit(Peek()) || !IsHexDigit(Peek(1))) {
              Fail(line_, "a \\x escape without two hexadecimal digits");
            }
            p_ += 2;
            decoded = '?';
            break;
          case 'b':
            decoded = '\b';
            break;
          case 'f':
            decoded = '\f';
            break;
          case 'n':
            decoded = '\n';
            break;
          case 'r':
            decoded = '\r';
            break;
          case 't':
            decoded = '\t';
            break;
          case 'u':
            for (int i = 0; i < 4; ++i) {
              if (!IsHexDigit(Peek(static_cast<size_t>(i)))) {
                Fail(line_, "a \\u escape without four hexadecimal digits");
              }
            }
            p_ += 4;
            decoded = '?';  // only numbers and the element type are read from strings
            break;
          default:
            Fail(line_, "an unknown escape in a string: \\", Quote(std::string_view(&escape, 1)));
        }
      }
      if (text != nullptr) *text += decoded;
    }
  }
};

// ---------------------------------------------------------------------------------------------
// The camera from the tree.

template <typename... Parts>
[[noreturn]] void FailAt(const std::string& name, int line, const Parts&... parts) {
  ThrowError(name, ": line ", line, ": ", parts...);
}

// A value, for messages.
std::string DescribeValue(const Node& node) {
  switch (node.kind) {
    case Node::Kind::kScalar:
    case Node::Kind::kString:
      return Quote(node.text);
    case Node::Kind::kEmpty:
      return "an empty value";
    case Node::Kind::kSequence:
      return "a list";
    case Node::Kind::kMap:
      return "a map";
    case Node::Kind::kBinary:
      return "binary data";
  }
  return "";
}

const Member* FindMember(const Node& map, std::string_view key) {
  if (map.kind != Node::Kind::kMap) return nullptr;
  for (const Member& member : map.members) {
    if (member.key == key) return &member;
  }
  return nullptr;
}

struct Matrix {
  int rows = 0;
  int cols = 0;
  std::vector<double> values;  // row by row
};

// An OpenCV matrix of one channel: rows, cols, dt, data (and type_id, which JSON writes as a key).
Matrix ReadMatrix(const Member& member, const std::string& name) {
  const Node& node = member.value;
  const std::string& field = member.key;
  auto fail = [&](int line, const auto&... parts) { FailAt(name, line, field, parts...); };
  if (node.kind != Node::Kind::kMap) {
    fail(member.line, " must be an OpenCV matrix with rows and cols");
  }
  std::string type = node.tag;
  const Member* rows_member = nullptr;
  const Member* cols_member = nullptr;
  const Member* dt_member = nullptr;
  const Member* data_member = nullptr;
  for (const Member& m : node.members) {
    if (m.key == "rows") {
      rows_member = &m;
    } else if (m.key == "cols") {
      cols_member = &m;
    } else if (m.key == "dt") {
      dt_member = &m;
    } else if (m.key == "data") {
      data_member = &m;
    } else if (m.key == "type_id" && m.value.kind == Node::Kind::kString) {
      type = m.value.text;
    } else if (m.key == "sizes") {
      fail(m.line, " must be a 2-dimensional OpenCV matrix with rows and cols, not one with sizes");
    } else {
      fail(m.line, " has the key ", Quote(m.key), ", which an OpenCV matrix does not have");
    }
  }
  if (!type.empty() && type != "opencv-matrix") {
    fail(member.line, " must be an OpenCV matrix (opencv-matrix), not ", Quote(type));
  }
  long long size[2] = {0, 0};
  const Member* size_members[2] = {rows_member, cols_member};
  for (int i = 0; i < 2; ++i) {
    bool out_of_range = false;
    if (size_members[i] == nullptr || size_members[i]->value.kind != Node::Kind::kScalar ||
        !ParseInteger(size_members[i]->value.text, &size[i], &out_of_range)) {
      fail(member.line, " must be an OpenCV matrix with rows and cols (whole numbers)");
    }
    if (out_of_range) {
      fail(size_members[i]->line, " has ", size_members[i]->value.text, " ",
           i == 0 ? "rows" : "cols", ", more than a camera file holds");
    }
  }
  const long long rows = size[0];
  const long long cols = size[1];
  if (rows < 0 || cols < 0) fail(member.line, " has a negative size, ", rows, "x", cols);
  if (rows > kMaxMatrixElements || cols > kMaxMatrixElements || rows * cols > kMaxMatrixElements) {
    fail(member.line, " has ", rows, "x", cols, " elements, more than a camera file holds");
  }
  if (dt_member == nullptr) fail(member.line, " has no dt (element type)");
  const Node& dt = dt_member->value;
  std::string_view depth;
  if (dt.kind == Node::Kind::kScalar || dt.kind == Node::Kind::kString) depth = dt.text;
  if (depth.size() == 2 && depth[0] == '1') depth.remove_prefix(1);
  if (depth.size() != 1 || !IsOneOf(depth[0], "ucwsifd")) {
    fail(dt_member->line, ": the element type (dt) ", Quote(dt.text),
         " is not supported; a camera file's matrices have one channel of u, c, w, s, i, f or d");
  }
  if (data_member == nullptr) fail(member.line, " has no data");
  const Node& data = data_member->value;
  std::vector<const Node*> items;
  size_t count = 0;
  if (data.kind == Node::Kind::kBinary) {
    fail(data_member->line,
         ": binary (base64) data is not supported; write the matrix as text numbers");
  }
  if (data.kind == Node::Kind::kMap) fail(data_member->line, ": data must be a list of numbers");
  if (data.kind == Node::Kind::kSequence) {
    for (const Node& item : data.items) items.push_back(&item);
    count = data.count;
  } else if (data.kind != Node::Kind::kEmpty) {  // one value
    items.push_back(&data);
    count = 1;
  }
  if (count != static_cast<size_t>(rows * cols)) {
    fail(data_member->line, " has ", rows, "x", cols, " = ", rows * cols, " elements but ", count,
         count == 1 ? " value" : " values", " in its data");
  }
  Matrix matrix;
  matrix.rows = static_cast<int>(rows);
  matrix.cols = static_cast<int>(cols);
  for (size_t i = 0; i < items.size(); ++i) {
    const Node& item = *items[i];
    double value = 0.0;
    const NumberKind kind =
        item.kind == Node::Kind::kScalar ? ParseNumber(item.text, &value) : NumberKind::kInvalid;
    const int line = item.line > 0 ? item.line : data_member->line;
    if (kind == NumberKind::kInvalid) {
      fail(line, ": value ", i + 1, " of the data is not a number: ", DescribeValue(item));
    }
    if (kind == NumberKind::kNotFinite) {
      fail(line, ": value ", i + 1, " of the data is not a finite number: ", Quote(item.text));
    }
    if (kind == NumberKind::kOutOfRange) {
      fail(line, ": value ", i + 1, " of the data is out of range: ", Quote(item.text));
    }
    double low = 0.0;
    double high = 0.0;
    switch (depth[0]) {
      case 'u':
        high = 255.0;
        break;
      case 'c':
        low = -128.0;
        high = 127.0;
        break;
      case 'w':
        high = 65535.0;
        break;
      case 's':
        low = -32768.0;
        high = 32767.0;
        break;
      case 'i':
        low = -2147483648.0;
        high = 2147483647.0;
        break;
      case 'f':
        if (std::abs(value) > static_cast<double>(std::numeric_limits<float>::max())) {
          fail(line, ": value ", i + 1, " of the data is out of range of dt f: ", Quote(item.text));
        }
        value = static_cast<double>(static_cast<float>(value));
        break;
      default:  // 'd'
        break;
    }
    if (depth[0] != 'f' && depth[0] != 'd' &&
        (value != std::floor(value) || value < low || value > high)) {
      fail(line, ": value ", i + 1, " of the data, ", Quote(item.text),
           ", is not a whole number in the range of dt ", depth[0]);
    }
    matrix.values.push_back(value);
  }
  return matrix;
}

// image_width or image_height.
int ReadSize(const Member& member, const std::string& name) {
  long long value = 0;
  bool out_of_range = false;
  if (member.value.kind != Node::Kind::kScalar ||
      !ParseInteger(member.value.text, &value, &out_of_range)) {
    ThrowError(name, ": line ", member.line,
               ": image_width and image_height must be whole numbers, not ",
               DescribeValue(member.value));
  }
  if (out_of_range || value < std::numeric_limits<int>::min() ||
      value > std::numeric_limits<int>::max()) {
    ThrowError(name, ": line ", member.line, ": ", member.key, " ", Quote(member.value.text),
               " is out of range");
  }
  return static_cast<int>(value);
}

// The file's text as a tree, by its first characters: "%YAML", "<?xml" or "{" (what OpenCV
// recognises, in this order).
Node ParseCameraText(std::string_view text, const std::string& name) {
  int line = 1;
  for (size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\n' && c != '\t') || c == 0x7f) {
      ThrowError(name, ": line ", line, ": a control character (byte ", static_cast<int>(c),
                 "); not an OpenCV YAML/XML/JSON camera file");
    }
    if (c == '\n') ++line;
  }
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // a UTF-8 byte order mark
  if (text.substr(0, 5) == "%YAML") return YamlReader(text, name).Read();
  size_t first = 0;
  while (first < text.size() && IsSpace(text[first])) ++first;
  if (text.substr(first, 5) == "<?xml") return XmlReader(text, name).Read();
  if (text.substr(first, 1) == "{") return JsonReader(text, name).Read();
  ThrowError(
      name, ": not an OpenCV YAML/XML/JSON camera file (it must begin with %YAML:1.0, <?xml or {)");
}

}  // namespace

PinholeCamera ReadCameraFile(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) ThrowError(name, ": no such camera file");
  // A camera file is a few hundred bytes of text: anything much larger or binary is refused
  // before it is parsed.
  constexpr std::uintmax_t kMaxBytes = 1 << 20;
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error) ThrowError(name, ": cannot read the camera file: ", error.message());
  if (bytes > kMaxBytes) {
    ThrowError(name, ": ", bytes, " bytes is too large for a camera file (at most ", kMaxBytes,
               ")");
  }
  std::string text;
  {
    std::ifstream stream(path, std::ios::binary);
    text.assign(std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>());
    if (!stream.eof() && !stream) ThrowError(name, ": cannot read the camera file");
  }
  if (text.size() > kMaxBytes) ThrowError(name, ": too large for a camera file");
  if (text.find('\0') != std::string::npos) {
    ThrowError(name, ": a binary file, not an OpenCV YAML/XML/JSON camera file");
  }
  // Line ends: CR LF as LF.
  std::string normalised;
  normalised.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (!(text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n')) normalised += text[i];
  }
  const Node root = ParseCameraText(normalised, name);

  const Member* matrix_member = FindMember(root, "camera_matrix");
  if (matrix_member == nullptr) ThrowError(name, ": no camera_matrix");
  const Matrix matrix = ReadMatrix(*matrix_member, name);
  Matrix distortion;
  if (const Member* member = FindMember(root, "distortion_coefficients")) {
    distortion = ReadMatrix(*member, name);
  }
  const Member* width_member = FindMember(root, "image_width");
  const Member* height_member = FindMember(root, "image_height");
  if (width_member == nullptr || height_member == nullptr) {
    ThrowError(name, ": no image_width/image_height");
  }
  PinholeCamera camera;
  camera.width_px = ReadSize(*width_member, name);
  camera.height_px = ReadSize(*height_member, name);
  if (matrix.rows != 3 || matrix.cols != 3) {
    ThrowError(name, ": camera_matrix must be a 3x3 matrix, got ", matrix.rows, "x", matrix.cols);
  }
  auto at = [&](int row, int col) { return matrix.values[static_cast<size_t>(row * 3 + col)]; };
  camera.focal_x_px = at(0, 0);
  camera.focal_y_px = at(1, 1);
  camera.principal_x_px = at(0, 2);
  camera.principal_y_px = at(1, 2);
  auto near = [](double value, double target) { return std::abs(value - target) <= 1e-9; };
  if (!near(at(0, 1), 0.0) || !near(at(1, 0), 0.0) || !near(at(2, 0), 0.0) ||
      !near(at(2, 1), 0.0) || !near(at(2, 2), 1.0)) {
    ThrowError(name, ": camera_matrix must have the form [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  if (!distortion.values.empty()) {
    if (distortion.rows != 1 && distortion.cols != 1) {
      ThrowError(name, ": distortion_coefficients must be a vector");
    }
    for (size_t i = 0; i < distortion.values.size(); ++i) {
      const double k = distortion.values[i];
      if (i < 5) {
        camera.distortion[i] = k;
      } else if (k != 0.0) {
        ThrowError(name, ": distortion coefficient ", i + 1,
                   " is non-zero; only k1 k2 p1 p2 k3 are supported");
      }
    }
  }
  std::string problem;
  if (!camera.CheckCalibration(&problem)) ThrowError(name, ": invalid camera: ", problem);
  return camera;
}

void WriteCameraFile(const std::filesystem::path& path, const PinholeCamera& camera) {
  std::string problem;
  if (!camera.Check(&problem))
    ThrowError(path.string(), ": cannot write an invalid camera: ", problem);
  try {
    cv::FileStorage storage(path.string(), cv::FileStorage::WRITE);
    if (!storage.isOpened()) ThrowError(path.string(), ": cannot open for writing");
    storage << "image_width" << camera.width_px;
    storage << "image_height" << camera.height_px;
    const cv::Mat matrix = (cv::Mat_<double>(3, 3) << camera.focal_x_px, 0.0, camera.principal_x_px,
                            0.0, camera.focal_y_px, camera.principal_y_px, 0.0, 0.0, 1.0);
    storage << "camera_matrix" << matrix;
    cv::Mat distortion(1, 5, CV_64F);
    for (int i = 0; i < 5; ++i)
      distortion.at<double>(0, i) = camera.distortion[static_cast<size_t>(i)];
    storage << "distortion_coefficients" << distortion;
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": cannot write camera file (", exception.err, ")");
  }
}

}  // namespace silpose
