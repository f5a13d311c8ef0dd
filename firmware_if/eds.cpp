#include "firmware_if/eds.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace dualv::fw::eds {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

bool is_hex(char c) { return std::isxdigit(static_cast<unsigned char>(c)) != 0; }

std::string hex4(std::uint16_t v) {
  char b[8];
  std::snprintf(b, sizeof b, "%04Xh", v);
  return b;
}

struct Value {
  std::string text;
  int line = 0;
};

struct Section {
  std::string name;  // as written
  int line = 0;
  std::map<std::string, Value> keys;  // lower-case key

  const Value* get(const std::string& key) const {
    const auto it = keys.find(key);
    return it == keys.end() ? nullptr : &it->second;
  }
};

// Integer data types of CiA 301 7.4.7.1 (values range-checked when they have a size here).
bool is_integer_type(std::uint16_t t) {
  return (t >= 0x01 && t <= 0x07) || t == 0x10 || (t >= 0x12 && t <= 0x1B);
}

bool fits(std::int64_t v, DataType t) {
  switch (t) {
    case DataType::kBoolean:
      return v == 0 || v == 1;
    case DataType::kInteger8:
      return v >= -128 && v <= 255;  // hex patterns (0xFF) of a signed type are accepted
    case DataType::kInteger16:
      return v >= -32768 && v <= 65535;
    case DataType::kInteger32:
      return v >= std::numeric_limits<std::int32_t>::min() && v <= 0xFFFFFFFFll;
    case DataType::kUnsigned8:
      return v >= 0 && v <= 0xFF;
    case DataType::kUnsigned16:
      return v >= 0 && v <= 0xFFFF;
    case DataType::kUnsigned32:
      return v >= 0 && v <= 0xFFFFFFFFll;
  }
  return false;
}

std::optional<DataType> known_type(std::uint16_t t) {
  if (t >= 0x01 && t <= 0x07) return static_cast<DataType>(t);
  return std::nullopt;
}

// "$NODEID+0x180", "0x180+$NODEID", "$NODEID", "0x80": the sum, for `node`.
std::optional<std::int64_t> evaluate(std::string_view text, std::uint8_t node, bool& uses_node) {
  uses_node = false;
  std::int64_t sum = 0;
  std::string_view rest = trim(text);
  if (rest.empty()) return std::nullopt;
  for (;;) {
    const std::size_t plus = rest.find('+', 1);  // a leading sign is the number's
    const std::string_view term = trim(rest.substr(0, plus));
    if (lower(term) == "$nodeid") {
      uses_node = true;
      sum += node;
    } else {
      const auto n = parse_number(term);
      // Far outside every CiA 301 integer: refused before the sum could overflow.
      if (!n || *n > (std::int64_t{1} << 40) || *n < -(std::int64_t{1} << 40)) return std::nullopt;
      sum += *n;
    }
    if (plus == std::string_view::npos) return sum;
    rest = rest.substr(plus + 1);
  }
}

std::optional<Access> parse_access(const std::string& a) {
  if (a == "ro") return Access::kRo;
  if (a == "wo") return Access::kWo;
  if (a == "rw" || a == "rwr" || a == "rww") return Access::kRw;
  if (a == "const") return Access::kConst;
  return std::nullopt;
}

class Parser {
 public:
  Parser(std::string_view text, std::string file) : text_(text), file_(std::move(file)) {}

  Eds run() {
    read_sections();
    Eds eds;
    eds.file = file_;
    std::map<std::uint16_t, std::vector<const Section*>> subs;  // by index
    std::map<std::uint16_t, const Section*> objects;
    for (const Section& s : sections_) {
      const std::string n = lower(s.name);
      const bool index_form =
          s.name.size() >= 4 && std::all_of(s.name.begin(), s.name.begin() + 4, is_hex);
      if (!index_form) {
        if (std::isdigit(static_cast<unsigned char>(s.name[0])))
          fail(s.line, "unknown section syntax [" + s.name +
                           "]: an object is [IIII], a sub-index [IIIIsubS] (hex, CiA 306 4.6)");
        if (n == "mandatoryobjects") list(s, eds.mandatory);
        if (n == "optionalobjects") list(s, eds.optional);
        if (n == "manufacturerobjects") list(s, eds.manufacturer);
        continue;  // [FileInfo], [DeviceInfo], [Comments], vendor sections: not interpreted
      }
      const std::string rest = n.substr(4);
      const auto index = static_cast<std::uint16_t>(std::stoul(s.name.substr(0, 4), nullptr, 16));
      if (rest.empty()) {
        objects[index] = &s;
      } else if (rest.rfind("sub", 0) == 0 && rest.size() > 3 && rest.size() <= 5 &&
                 std::all_of(rest.begin() + 3, rest.end(), is_hex)) {
        subs[index].push_back(&s);
      } else if (rest == "name" || rest == "value" || rest == "denotation") {
        continue;  // compact sub-object names / DCF values: not interpreted
      } else {
        fail(s.line, "unknown section syntax [" + s.name +
                         "]: an object is [IIII], a sub-index [IIIIsubS] (hex, CiA 306 4.6)");
      }
    }
    for (const auto& [index, list] : subs)
      if (!objects.count(index))
        fail(list.front()->line, "[" + list.front()->name + "] without its object section [" +
                                     hex4(index).substr(0, 4) + "]");
    for (const auto& [index, s] : objects) eds.objects.push_back(object(index, *s, subs[index]));
    check_lists(eds, objects);
    return eds;
  }

 private:
  [[noreturn]] void fail(int line, const std::string& reason) const {
    throw EdsError(file_, line, reason);
  }

  void read_sections() {
    std::map<std::string, int> seen;  // lower-case name -> line
    int line_no = 0;
    std::size_t pos = 0;
    while (pos <= text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos), text_.size());
      const std::string_view line = trim(text_.substr(pos, end - pos));
      pos = end + 1;
      ++line_no;
      if (line.empty() || line.front() == ';' || line.front() == '#') continue;
      if (line.front() == '[') {
        if (line.back() != ']') fail(line_no, "section header without ']': " + std::string(line));
        const std::string name(trim(line.substr(1, line.size() - 2)));
        if (name.empty()) fail(line_no, "empty section name []");
        const auto [it, fresh] = seen.emplace(lower(name), line_no);
        if (!fresh)
          fail(line_no, "duplicate section [" + name + "] (first at line " +
                            std::to_string(it->second) + ")");
        sections_.push_back(Section{name, line_no, {}});
        continue;
      }
      const std::size_t eq = line.find('=');
      if (eq == std::string_view::npos || trim(line.substr(0, eq)).empty())
        fail(line_no, "not a [section] or key=value line: " + std::string(line));
      if (sections_.empty()) fail(line_no, "key=value before the first [section]");
      Section& s = sections_.back();
      const std::string key = lower(trim(line.substr(0, eq)));
      const auto [it, fresh] =
          s.keys.emplace(key, Value{std::string(trim(line.substr(eq + 1))), line_no});
      if (!fresh)
        fail(line_no, "duplicate key " + std::string(trim(line.substr(0, eq))) + " in [" + s.name +
                          "] (first at line " + std::to_string(it->second.line) + ")");
    }
  }

  const Value& need(const Section& s, const std::string& key, const char* written) const {
    const Value* v = s.get(key);
    if (v == nullptr) fail(s.line, "[" + s.name + "] lacks " + written);
    return *v;
  }

  std::int64_t number(const Value& v, const char* key, std::int64_t lo, std::int64_t hi) const {
    const auto n = parse_number(v.text);
    if (!n) fail(v.line, std::string("bad number for ") + key + ": '" + v.text + "'");
    if (*n < lo || *n > hi)
      fail(v.line, std::string(key) + " = " + v.text + " is outside " + std::to_string(lo) + ".." +
                       std::to_string(hi));
    return *n;
  }

  // A value of the entry's type: DefaultValue (may use $NODEID), LowLimit, HighLimit.
  void check_value(const Value* v, const char* key, const EdsEntry& e, bool node_allowed) const {
    if (v == nullptr || v->text.empty() || !is_integer_type(e.data_type)) return;
    bool uses_node = false;
    const auto n = evaluate(v->text, 1, uses_node);
    if (!n || (uses_node && !node_allowed))
      fail(v->line, std::string("bad number for ") + key + ": '" + v->text + "'" +
                        (node_allowed ? " (a number, or $NODEID + a number)" : ""));
    const auto t = known_type(e.data_type);
    if (t && !uses_node && !fits(*n, *t))
      fail(v->line,
           std::string(key) + " = " + v->text + " does not fit " + data_type_name(e.data_type));
  }

  EdsEntry entry(std::uint16_t index, std::uint8_t sub, const Section& s) const {
    EdsEntry e;
    e.index = index;
    e.subindex = sub;
    e.line = s.line;
    e.name = need(s, "parametername", "ParameterName").text;
    e.data_type =
        static_cast<std::uint16_t>(number(need(s, "datatype", "DataType"), "DataType", 0, 0xFFFF));
    const Value& a = need(s, "accesstype", "AccessType");
    e.access_text = lower(a.text);
    const auto access = parse_access(e.access_text);
    if (!access) fail(a.line, "AccessType '" + a.text + "' is none of ro, wo, rw, rwr, rww, const");
    e.access = *access;
    if (const Value* p = s.get("pdomapping")) e.pdo_mappable = number(*p, "PDOMapping", 0, 1) == 1;
    const Value* d = s.get("defaultvalue");
    const Value* lo = s.get("lowlimit");
    const Value* hi = s.get("highlimit");
    check_value(d, "DefaultValue", e, true);
    check_value(lo, "LowLimit", e, false);
    check_value(hi, "HighLimit", e, false);
    if (d) e.default_value = d->text;
    if (lo) e.low_limit = lo->text;
    if (hi) e.high_limit = hi->text;
    return e;
  }

  EdsObject object(std::uint16_t index, const Section& s,
                   const std::vector<const Section*>& sub_sections) const {
    EdsObject o;
    o.index = index;
    o.line = s.line;
    o.name = need(s, "parametername", "ParameterName").text;
    if (const Value* t = s.get("objecttype")) {
      const auto code = number(*t, "ObjectType", 0, 0xFF);
      if (code != 0x0 && code != 0x2 && code != 0x5 && code != 0x6 && code != 0x7 && code != 0x8 &&
          code != 0x9)
        fail(t->line, "ObjectType " + t->text +
                          " is none of 0 NULL, 2 DOMAIN, 5 DEFTYPE, 6 DEFSTRUCT, 7 VAR, 8 ARRAY, "
                          "9 RECORD (CiA 301 table 42)");
      o.object_type = static_cast<ObjectType>(code);
    }
    if (const Value* c = s.get("compactsubobj"); c && parse_number(c->text).value_or(0) != 0)
      fail(c->line, "CompactSubObj is not supported: write one [IIIIsubS] section per sub-index");
    const bool aggregate = o.object_type == ObjectType::kArray ||
                           o.object_type == ObjectType::kRecord ||
                           o.object_type == ObjectType::kDefStruct;
    if (!aggregate) {
      if (!sub_sections.empty())
        fail(sub_sections.front()->line, "[" + sub_sections.front()->name + "]: object " +
                                             hex4(index) + " is a " + to_string(o.object_type) +
                                             ", which has no sub-index sections");
      o.entries.push_back(entry(index, 0, s));
      return o;
    }
    const Value& n = need(s, "subnumber", "SubNumber");
    o.sub_number = static_cast<std::uint8_t>(number(n, "SubNumber", 1, 255));
    if (sub_sections.size() != o.sub_number)
      fail(n.line, "SubNumber=" + n.text + " but " + std::to_string(sub_sections.size()) +
                       " sub-index sections of " + hex4(index) + " follow");
    for (const Section* sub : sub_sections) {
      const unsigned long k = std::stoul(sub->name.substr(7), nullptr, 16);
      if (k > 0xFF) fail(sub->line, "sub-index of [" + sub->name + "] is above FFh");
      for (const EdsEntry& e : o.entries)
        if (e.subindex == k)
          fail(sub->line, "[" + sub->name + "] repeats sub-index " + std::to_string(k) + " (line " +
                              std::to_string(e.line) + ")");
      o.entries.push_back(entry(index, static_cast<std::uint8_t>(k), *sub));
    }
    std::sort(o.entries.begin(), o.entries.end(),
              [](const EdsEntry& a, const EdsEntry& b) { return a.subindex < b.subindex; });
    return o;
  }

  void list(const Section& s, std::vector<std::uint16_t>& out) {
    const Value& count = need(s, "supportedobjects", "SupportedObjects");
    const auto n = number(count, "SupportedObjects", 0, 0xFFFF);
    if (static_cast<std::int64_t>(s.keys.size()) != n + 1)
      fail(count.line, "SupportedObjects=" + count.text + " but [" + s.name + "] has " +
                           std::to_string(s.keys.size() - 1) + " entries");
    for (std::int64_t i = 1; i <= n; ++i) {
      const Value& v = need(s, std::to_string(i), ("entry " + std::to_string(i)).c_str());
      out.push_back(static_cast<std::uint16_t>(number(v, "object index", 1, 0xFFFF)));
      list_lines_[out.back()] = v.line;
    }
  }

  void check_lists(const Eds& eds, const std::map<std::uint16_t, const Section*>& objects) const {
    std::map<std::uint16_t, int> listed;
    for (const auto* l : {&eds.mandatory, &eds.optional, &eds.manufacturer})
      for (std::uint16_t i : *l) {
        const int line = list_lines_.at(i);
        if (!listed.emplace(i, line).second)
          fail(line, hex4(i) + " is listed twice in the object lists");
        if (!objects.count(i))
          fail(line, hex4(i) + " is listed but has no [" + hex4(i).substr(0, 4) + "] section");
      }
    for (const auto& [index, s] : objects)
      if (!listed.count(index))
        fail(s->line, "[" + s->name +
                          "] is in none of [MandatoryObjects], [OptionalObjects], "
                          "[ManufacturerObjects]");
  }

  std::string_view text_;
  std::string file_;
  std::vector<Section> sections_;
  std::map<std::uint16_t, int> list_lines_;  // listed index -> line of its list entry
};

}  // namespace

const char* to_string(ObjectType t) noexcept {
  switch (t) {
    case ObjectType::kNull:
      return "NULL";
    case ObjectType::kDomain:
      return "DOMAIN";
    case ObjectType::kDefType:
      return "DEFTYPE";
    case ObjectType::kDefStruct:
      return "DEFSTRUCT";
    case ObjectType::kVar:
      return "VAR";
    case ObjectType::kArray:
      return "ARRAY";
    case ObjectType::kRecord:
      return "RECORD";
  }
  return "?";
}

const char* to_string(Access a) noexcept {
  switch (a) {
    case Access::kRo:
      return "ro";
    case Access::kWo:
      return "wo";
    case Access::kRw:
      return "rw";
    case Access::kConst:
      return "const";
  }
  return "?";
}

std::string data_type_name(std::uint16_t t) {
  static const char* const kNames[] = {"",          "BOOLEAN",       "INTEGER8",   "INTEGER16",
                                       "INTEGER32", "UNSIGNED8",     "UNSIGNED16", "UNSIGNED32",
                                       "REAL32",    "VISIBLE_STRING"};
  if (t >= 1 && t <= 9) return kNames[t];
  return hex4(t);
}

std::optional<DataType> EdsEntry::type() const noexcept { return known_type(data_type); }

const EdsObject* Eds::object(std::uint16_t index) const noexcept {
  for (const EdsObject& o : objects)
    if (o.index == index) return &o;
  return nullptr;
}

const EdsEntry* Eds::entry(std::uint16_t index, std::uint8_t subindex) const noexcept {
  const EdsObject* o = object(index);
  if (o == nullptr) return nullptr;
  for (const EdsEntry& e : o->entries)
    if (e.subindex == subindex) return &e;
  return nullptr;
}

EdsError::EdsError(const std::string& file, int line, const std::string& reason)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                         reason),
      file_(file),
      line_(line) {}

std::optional<std::int64_t> parse_number(std::string_view text) noexcept {
  text = trim(text);
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  if (text.empty()) return std::nullopt;
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    text.remove_prefix(2);
  } else if (text.size() > 1 && text[0] == '0') {
    base = 8;
    text.remove_prefix(1);
  }
  if (negative && base != 10) return std::nullopt;
  std::int64_t v = 0;
  for (char c : text) {
    int d = -1;
    if (c >= '0' && c <= '9') d = c - '0';
    if (c >= 'a' && c <= 'f') d = c - 'a' + 10;
    if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
    if (d < 0 || d >= base) return std::nullopt;
    if (v > (std::numeric_limits<std::int64_t>::max() - d) / base) return std::nullopt;
    v = v * base + d;
  }
  return negative ? -v : v;
}

std::optional<std::uint32_t> default_value(const EdsEntry& e, std::uint8_t node_id) noexcept {
  if (e.default_value.empty() || !is_integer_type(e.data_type)) return std::nullopt;
  bool uses_node = false;
  const auto v = evaluate(e.default_value, node_id, uses_node);
  if (!v) return std::nullopt;
  const auto raw = static_cast<std::uint32_t>(static_cast<std::uint64_t>(*v) & 0xFFFFFFFFu);
  const auto t = e.type();
  if (!t || size_of(*t) >= 4) return raw;
  return raw & ((1u << (8 * size_of(*t))) - 1u);
}

Eds parse_eds(std::string_view text, const std::string& file) { return Parser(text, file).run(); }

Eds read_eds_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw EdsError(path, 0, "cannot be read (no such file, or no permission)");
  std::ostringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  if (text.find('\0') != std::string::npos)
    throw EdsError(path, 0, "is binary, not an EDS text (CiA 306)");
  return parse_eds(text, path);
}

}  // namespace dualv::fw::eds
