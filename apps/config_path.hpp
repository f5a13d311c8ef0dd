#pragma once
// Where `dualv` finds its files. The configuration: --config FILE, else $DUALV_CONFIG, else
// dualv.yaml in the build's default config folder. Every other default (the program
// paper.yaml, the command key folder keys/, a program named in a signed start) comes from
// that same default config folder, NOT from the folder of a --config file: the folder is
// fixed when the binary is built (DUALV_CONFIG_DIR in apps/CMakeLists.txt: the source tree's
// config/ for a developer build, /etc/dualv for the installed package), and the help texts
// below print it, so `--help` says where a default really comes from (issue 14, defect 7).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <string>

#ifndef DUALV_DEFAULT_CONFIG_DIR
#define DUALV_DEFAULT_CONFIG_DIR "/etc/dualv"
#endif

namespace dualv::apps {

inline std::string default_config_dir() { return DUALV_DEFAULT_CONFIG_DIR; }
inline std::string default_program_file() { return default_config_dir() + "/paper.yaml"; }
inline std::string default_keys_dir() { return default_config_dir() + "/keys"; }

inline std::string config_help() {
  return "Robot configuration YAML (default: $DUALV_CONFIG, else " + default_config_dir() +
         "/dualv.yaml)";
}
inline std::string program_help() {
  return "Program YAML (default: " + default_program_file() + ")";
}
inline std::string keys_help() {
  return "Folder of command keys (default: " + default_keys_dir() + ")";
}

inline void add_config_option(CLI::App& cmd, std::string& config) {
  cmd.add_option("-c,--config", config, config_help());
}

inline std::string resolve_config(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* env = std::getenv("DUALV_CONFIG"); env != nullptr && *env != '\0') return env;
  return default_config_dir() + "/dualv.yaml";
}

inline std::string resolve_program(const std::string& given) {
  return given.empty() ? default_program_file() : given;
}

inline std::string resolve_keys_dir(const std::string& given) {
  return given.empty() ? default_keys_dir() : given;
}

// A program named in a signed start (`dualv start NAME`): NAME as a path, else NAME or
// NAME.yaml in the default config folder.
inline std::string resolve_named_program(const std::string& name) {
  if (std::filesystem::exists(name)) return name;
  const std::string in_dir = default_config_dir() + "/" + name;
  if (std::filesystem::exists(in_dir)) return in_dir;
  return in_dir + ".yaml";
}

}  // namespace dualv::apps
