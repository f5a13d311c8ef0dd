#pragma once
// Strict YAML reading for set-up code: every problem is collected with its key
// path, unknown keys are errors, and finish() throws ConfigError listing them
// all, so a caller never sees a half-read configuration.
#include <yaml-cpp/yaml.h>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/config_error.hpp"

namespace dualv {

class YamlReader {
 public:
  // A map node at `path` (e.g. "model.plate"); `path` prefixes every message.
  YamlReader(YAML::Node node, std::string path, std::vector<std::string>* problems);

  // Loads a file strictly (issue 14): a missing, empty, binary or non-YAML file, a YAML
  // syntax error, a top level that is not a map, a duplicate key anywhere and a key without
  // a value (`key: ~`, `key:`) each become a problem "<file>:<line>:<col>: <key path>:
  // <reason>"; all of them are thrown at once as one ConfigError.
  // With `document_problems`, the duplicate keys and empty values are appended there instead
  // of thrown (a caller that goes on to report the file's other problems at once); a file
  // that is not a YAML map still throws.
  static YAML::Node load_file(const std::string& file,
                              std::vector<std::string>* document_problems = nullptr);
  // The same checks on text already in memory; `name` stands for the file in messages.
  static YAML::Node load_text(const std::string& text, const std::string& name,
                              std::vector<std::string>* document_problems = nullptr);

  // While alive, every reader on this thread ignores its fallbacks: a key the code would
  // default must be in the file ("missing (a complete configuration gives every key...)").
  // A robot configuration is loaded under it, so defaults live in the shipped
  // config/dualv.yaml and a truncated file is refused, not completed from code.
  class CompleteFile {
   public:
    CompleteFile();
    ~CompleteFile();
    CompleteFile(const CompleteFile&) = delete;
    CompleteFile& operator=(const CompleteFile&) = delete;

   private:
    bool previous_;
  };

  const std::string& path() const noexcept { return path_; }
  bool has(const std::string& key) const;
  // Reads a required (or, with a fallback, optional) value; records a problem
  // and returns the fallback when it is missing or of the wrong type.
  double number(const std::string& key, std::optional<double> fallback = std::nullopt);
  int integer(const std::string& key, std::optional<int> fallback = std::nullopt);
  bool boolean(const std::string& key, std::optional<bool> fallback = std::nullopt);
  std::string string(const std::string& key, std::optional<std::string> fallback = std::nullopt);
  std::vector<double> numbers(const std::string& key,
                              std::optional<std::vector<double>> fallback = std::nullopt);
  // Sub-map and sequence of maps; an absent optional child yields an empty node.
  YamlReader child(const std::string& key, bool required = true);
  std::vector<YamlReader> children(const std::string& key, bool required = true);

  // Value checks: record "<path>.<key>: must be ... (got v)" when false.
  void require(bool ok, const std::string& key, const std::string& rule, double got);
  void require(bool ok, const std::string& key, const std::string& rule);
  double positive(const std::string& key, std::optional<double> fallback = std::nullopt);
  double non_negative(const std::string& key, std::optional<double> fallback = std::nullopt);
  double in_range(const std::string& key, double lo, double hi,
                  std::optional<double> fallback = std::nullopt);

  // Records every key of this map that was never read as "unknown key".
  void reject_unknown_keys();
  void problem(const std::string& message);
  std::string key_path(const std::string& key) const;
  bool valid() const noexcept { return node_.IsDefined() && !node_.IsNull(); }

 private:
  std::optional<YAML::Node> get(const std::string& key, bool required);
  std::optional<YAML::Node> lookup(const std::string& key) const;
  YAML::Node node_;
  std::string path_;
  std::vector<std::string>* problems_;
  std::vector<std::string> read_keys_;
};

// Collects problems across readers; finish() throws if there are any.
class ConfigProblems {
 public:
  std::vector<std::string>* sink() noexcept { return &problems_; }
  bool empty() const noexcept { return problems_.empty(); }
  void finish() const;  // throws ConfigError

 private:
  std::vector<std::string> problems_;
};

// Runs `load` and prefixes every problem of a ConfigError it throws with "<file>: ", so a
// section loader's messages name the file they came from.
void prefix_problems(const std::string& file, const std::function<void()>& load);

}  // namespace dualv
