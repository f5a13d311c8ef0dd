#pragma once
// Where `dualv` finds its configuration: --config FILE, else $DUALV_CONFIG, else
// dualv.yaml in the build's default config folder (the source tree for a
// developer build, /etc/dualv for the installed package).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <string>

#ifndef DUALV_DEFAULT_CONFIG_DIR
#define DUALV_DEFAULT_CONFIG_DIR "/etc/dualv"
#endif

namespace dualv::apps {

inline std::string default_config_dir() { return DUALV_DEFAULT_CONFIG_DIR; }

inline void add_config_option(CLI::App& cmd, std::string& config) {
  cmd.add_option("-c,--config", config,
                 "Robot configuration YAML (default: " + default_config_dir() + "/dualv.yaml)");
}

inline std::string resolve_config(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* env = std::getenv("DUALV_CONFIG")) return env;
  return default_config_dir() + "/dualv.yaml";
}

}  // namespace dualv::apps
