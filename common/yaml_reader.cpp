#include "common/yaml_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace dualv {

namespace {
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

YAML::Node YamlReader::load_file(const std::string& file) {
  try {
    return YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw ConfigError({fmt::format("{}: cannot open file", file)});
  } catch (const YAML::Exception& e) {
    throw ConfigError({fmt::format("{}:{}:{}: YAML syntax error: {}", file, e.mark.line + 1,
                                   e.mark.column + 1, e.msg)});
  }
}

std::string YamlReader::key_path(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void YamlReader::problem(const std::string& message) { problems_->push_back(message); }

bool YamlReader::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

std::optional<YAML::Node> YamlReader::get(const std::string& key, bool required) {
  read_keys_.push_back(key);
  if (!has(key)) {
    if (required) problem(fmt::format("{}: missing", key_path(key)));
    return std::nullopt;
  }
  const YAML::Node& map = node_;  // const lookup: never inserts the key
  return map[key];
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
