#include "common/yaml_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <new>

namespace dualv {

namespace {

thread_local bool complete_file = false;

// Bounds that keep a hostile file from costing more than a refusal.
constexpr std::size_t kMaxFileBytes = 4u << 20;  // a configuration or program is a few kB
constexpr std::size_t kMaxNodes = 200000;        // walked nodes (aliases re-visit theirs)

std::string node_kind(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Scalar:
      return "a single value";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

// The first byte that cannot be in a YAML text file (YAML 1.2 section 5.1: printable
// characters, tab, CR, LF), or npos.
std::size_t first_binary_byte(const std::string& text) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7f) return i;
  }
  return std::string::npos;
}

// Walks the parsed document: duplicate keys (yaml-cpp keeps both pairs, a lookup sees the
// first) and keys or list items without a value. Stops after kMaxNodes.
class DocumentCheck {
 public:
  DocumentCheck(const std::string& name, std::vector<std::string>& problems)
      : name_(name), problems_(problems) {}

  void walk(const YAML::Node& n, const std::string& path) {
    if (++visited_ > kMaxNodes) {
      if (visited_ == kMaxNodes + 1)
        add(n.Mark(), path,
            fmt::format("more than {} values (aliases?): not a configuration", kMaxNodes));
      return;
    }
    if (n.IsMap()) {
      std::vector<std::pair<std::string, int>> seen;
      for (const auto& kv : n) {
        const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "<complex key>";
        const std::string child = path.empty() ? key : path + "." + key;
        const auto first =
            std::find_if(seen.begin(), seen.end(), [&](const auto& s) { return s.first == key; });
        if (first != seen.end()) {
          add(kv.first.Mark(), child,
              fmt::format("duplicate key (first at line {}; YAML allows a key once per map)",
                          first->second));
        } else {
          seen.emplace_back(key, kv.first.Mark().line + 1);
        }
        if (!kv.first.IsScalar()) add(kv.first.Mark(), child, "a key must be a plain name");
        check_value(kv.second, kv.first.Mark(), child);
      }
    } else if (n.IsSequence()) {
      for (std::size_t i = 0; i < n.size(); ++i)
        check_value(n[i], n.Mark(), fmt::format("{}[{}]", path, i));
    }
  }

 private:
  void check_value(const YAML::Node& v, const YAML::Mark& at, const std::string& path) {
    if (v.IsNull()) {
      add(v.Mark().is_null() ? at : v.Mark(), path,
          "no value (empty or ~): give a value; defaults are in the shipped config/dualv.yaml");
      return;
    }
    walk(v, path);
  }
  void add(const YAML::Mark& m, const std::string& path, const std::string& reason) {
    if (m.is_null())
      problems_.push_back(fmt::format("{}: {}: {}", name_, path, reason));
    else
      problems_.push_back(
          fmt::format("{}:{}:{}: {}: {}", name_, m.line + 1, m.column + 1, path, reason));
  }
  const std::string& name_;
  std::vector<std::string>& problems_;
  std::size_t visited_ = 0;
};

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out = "invalid configuration:";
  for (const auto& l : lines) out += "\n  " + l;
  return out;
}
}  // namespace

ConfigError::ConfigError(std::vector<std::string> problems)
    : std::runtime_error(join_lines(problems)), problems_(std::move(problems)) {}

void ConfigProblems::finish() const {
  if (!problems_.empty()) throw ConfigError(problems_);
}

YamlReader::YamlReader(YAML::Node node, std::string path, std::vector<std::string>* problems)
    : node_(std::move(node)), path_(std::move(path)), problems_(problems) {
  if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap())
    problem(fmt::format("{}: must be a map of keys", path_.empty() ? "<root>" : path_));
}

YAML::Node YamlReader::load_file(const std::string& file,
                                 std::vector<std::string>* document_problems) {
  std::ifstream in(file, std::ios::binary);
  if (!in)
    throw ConfigError({fmt::format("{}: cannot open file ({})", file, std::strerror(errno))});
  std::string text;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxFileBytes)
      throw ConfigError(
          {fmt::format("{}: not a YAML configuration: larger than {} bytes", file, kMaxFileBytes)});
  }
  if (in.bad()) throw ConfigError({fmt::format("{}: cannot read file", file)});
  return load_text(text, file, document_problems);
}

YAML::Node YamlReader::load_text(const std::string& text, const std::string& name,
                                 std::vector<std::string>* document_problems) {
  if (text.size() > kMaxFileBytes)
    throw ConfigError(
        {fmt::format("{}: not a YAML configuration: larger than {} bytes", name, kMaxFileBytes)});
  if (const std::size_t at = first_binary_byte(text); at != std::string::npos)
    throw ConfigError({fmt::format(
        "{}: not a YAML file: binary content (byte 0x{:02x} at offset {}); expected a text file",
        name, static_cast<unsigned char>(text[at]), at)});
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError({fmt::format("{}:{}:{}: YAML syntax error (not a valid YAML file): {}", name,
                                   e.mark.line + 1, e.mark.column + 1, e.msg)});
  } catch (const std::bad_alloc&) {
    throw ConfigError({fmt::format("{}: not a YAML configuration: too large to parse", name)});
  }
  if (root.IsNull())
    throw ConfigError({fmt::format(
        "{}: empty file (only comments or nothing): expected a map of sections", name)});
  if (!root.IsMap())
    throw ConfigError({fmt::format(
        "{}: not a YAML configuration: the top level is {}, expected a map of sections (key: ...)",
        name, node_kind(root))});
  std::vector<std::string> problems;
  DocumentCheck(name, problems).walk(root, "");
  if (document_problems != nullptr)
    document_problems->insert(document_problems->end(), problems.begin(), problems.end());
  else if (!problems.empty())
    throw ConfigError(problems);
  return root;
}

YamlReader::CompleteFile::CompleteFile() : previous_(complete_file) { complete_file = true; }
YamlReader::CompleteFile::~CompleteFile() { complete_file = previous_; }

void prefix_problems(const std::string& file, const std::function<void()>& load) {
  try {
    load();
  } catch (const ConfigError& e) {
    std::vector<std::string> named;
    const std::string prefix = file + ":";
    for (const auto& p : e.problems())
      named.push_back(p.rfind(prefix, 0) == 0 ? p : fmt::format("{}: {}", file, p));
    throw ConfigError(std::move(named));
  }
}

std::string YamlReader::key_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void YamlReader::problem(const std::string& message) { problems_->push_back(message); }

// One look-up per key: the value, or nothing when node_ is not a map or has no such key.
// The first pair whose key is a scalar equal to `key`, as yaml-cpp's const operator[] finds
// (node_data::get: convert<std::string>::decode then ==), but compared in place: yaml-cpp
// copies every key it passes into a new std::string, one allocation per key under the fuzz
// build's AddressSanitizer (robot_config_fuzz spent a tenth of its time in these look-ups).
std::optional<YAML::Node> YamlReader::lookup(const std::string& key) const {
  if (!node_.IsMap()) return std::nullopt;
  const YAML::Node& map = node_;  // const iteration: never inserts anything
  for (const auto& kv : map)
    if (kv.first.IsScalar() && kv.first.Scalar() == key) return kv.second;
  return std::nullopt;
}

bool YamlReader::has(const std::string& key) const {
  const auto v = lookup(key);
  return v && v->IsDefined() && !v->IsNull();
}

std::optional<YAML::Node> YamlReader::get(const std::string& key, bool required) {
  read_keys_.push_back(key);
  const std::optional<YAML::Node> v = lookup(key);
  if (v && v->IsDefined() && v->IsNull()) {
    problem(fmt::format("{}: no value (empty or ~): give a value", key_path(key)));
    return std::nullopt;
  }
  if (!(v && v->IsDefined())) {
    if (complete_file && !required && valid())
      problem(fmt::format(
          "{}: missing (a complete configuration gives every key; see config/dualv.yaml)",
          key_path(key)));
    else if (required)
      problem(fmt::format("{}: missing", key_path(key)));
    return std::nullopt;
  }
  return v;
}

double YamlReader::number(const std::string& key, std::optional<double> fallback) {
  const auto found = get(key, !fallback.has_value());
  if (!found) return fallback.value_or(0.0);
  const YAML::Node& n = *found;
  try {
    if (!n.IsScalar()) throw YAML::Exception(YAML::Mark(), "not a scalar");
    double v = n.as<double>();
    if (!std::isfinite(v)) {
      problem(fmt::format("{}: must be a finite number (got {})", key_path(key), n.Scalar()));
      return fallback.value_or(0.0);
    }
    return v;
  } catch (const YAML::Exception&) {
    problem(fmt::format("{}: must be a number (got '{}')", key_path(key),
                        n.IsScalar() ? n.Scalar() : std::string("a non-scalar")));
    return fallback.value_or(0.0);
  }
}

int YamlReader::integer(const std::string& key, std::optional<int> fallback) {
  const auto found = get(key, !fallback.has_value());
  if (!found) return fallback.value_or(0);
  const YAML::Node& n = *found;
  try {
    if (!n.IsScalar()) throw YAML::Exception(YAML::Mark(), "not a scalar");
    return n.as<int>();
  } catch (const YAML::Exception&) {
    problem(fmt::format("{}: must be an integer (got '{}')", key_path(key),
                        n.IsScalar() ? n.Scalar() : std::string("a non-scalar")));
    return fallback.value_or(0);
  }
}

bool YamlReader::boolean(const std::string& key, std::optional<bool> fallback) {
  const auto found = get(key, !fallback.has_value());
  if (!found) return fallback.value_or(false);
  const YAML::Node& n = *found;
  try {
    if (!n.IsScalar()) throw YAML::Exception(YAML::Mark(), "not a scalar");
    return n.as<bool>();
  } catch (const YAML::Exception&) {
    problem(fmt::format("{}: must be true or false (got '{}')", key_path(key),
                        n.IsScalar() ? n.Scalar() : std::string("a non-scalar")));
    return fallback.value_or(false);
  }
}

std::string YamlReader::string(const std::string& key, std::optional<std::string> fallback) {
  const auto found = get(key, !fallback.has_value());
  if (!found) return fallback.value_or("");
  const YAML::Node& n = *found;
  if (!n.IsScalar()) {
    problem(fmt::format("{}: must be a string", key_path(key)));
    return fallback.value_or("");
  }
  return n.Scalar();
}

std::vector<double> YamlReader::numbers(const std::string& key,
                                        std::optional<std::vector<double>> fallback) {
  const auto found = get(key, !fallback.has_value());
  if (!found) return fallback.value_or(std::vector<double>{});
  const YAML::Node& n = *found;
  if (!n.IsSequence()) {
    problem(fmt::format("{}: must be a list of numbers", key_path(key)));
    return fallback.value_or(std::vector<double>{});
  }
  std::vector<double> out;
  for (std::size_t i = 0; i < n.size(); ++i) {
    try {
      double v = n[i].as<double>();
      if (!std::isfinite(v)) throw YAML::Exception(YAML::Mark(), "not finite");
      out.push_back(v);
    } catch (const YAML::Exception&) {
      problem(fmt::format("{}[{}]: must be a finite number", key_path(key), i));
      out.push_back(0.0);
    }
  }
  return out;
}

YamlReader YamlReader::child(const std::string& key, bool required) {
  const auto found = get(key, required);
  return YamlReader(found ? *found : YAML::Node(YAML::NodeType::Null), key_path(key), problems_);
}

std::vector<YamlReader> YamlReader::children(const std::string& key, bool required) {
  const auto found = get(key, required);
  std::vector<YamlReader> out;
  if (!found) return out;
  const YAML::Node& n = *found;
  if (!n.IsSequence()) {
    problem(fmt::format("{}: must be a list", key_path(key)));
    return out;
  }
  for (std::size_t i = 0; i < n.size(); ++i)
    out.emplace_back(n[i], fmt::format("{}[{}]", key_path(key), i), problems_);
  return out;
}

void YamlReader::require(bool ok, const std::string& key, const std::string& rule, double got) {
  if (!ok) problem(fmt::format("{}: {} (got {})", key_path(key), rule, got));
}

void YamlReader::require(bool ok, const std::string& key, const std::string& rule) {
  if (!ok) problem(fmt::format("{}: {}", key_path(key), rule));
}

double YamlReader::positive(const std::string& key, std::optional<double> fallback) {
  const bool present = has(key);
  double v = number(key, fallback);
  if (present) require(v > 0.0, key, "must be > 0", v);
  return v;
}

double YamlReader::non_negative(const std::string& key, std::optional<double> fallback) {
  const bool present = has(key);
  double v = number(key, fallback);
  if (present) require(v >= 0.0, key, "must be >= 0", v);
  return v;
}

double YamlReader::in_range(const std::string& key, double lo, double hi,
                            std::optional<double> fallback) {
  const bool present = has(key);
  double v = number(key, fallback);
  if (present) require(v >= lo && v <= hi, key, fmt::format("must be in [{}, {}]", lo, hi), v);
  return v;
}

void YamlReader::reject_unknown_keys() {
  if (!node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.as<std::string>();
    if (std::find(read_keys_.begin(), read_keys_.end(), k) == read_keys_.end())
      problem(fmt::format("{}: unknown key", key_path(k)));
  }
}

}  // namespace dualv
