#pragma once
// Set-up errors: configuration problems collected with the key that caused them.
#include <stdexcept>
#include <string>
#include <vector>

namespace dualv {

// Thrown by set-up code (never by the real-time path). what() lists every
// problem found, one per line, each naming its key, e.g.
//   "model.chains[2].crank.length: must be > 0 (got -0.28)".
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(std::vector<std::string> problems);
  const std::vector<std::string>& problems() const noexcept { return problems_; }

 private:
  std::vector<std::string> problems_;
};

}  // namespace dualv
