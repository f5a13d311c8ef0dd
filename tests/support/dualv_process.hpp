#pragma once
// The real `dualv` binary as a child process for the CLI tests (tests/apps): its output (stdout
// and stderr) in a log file, environment variables set or removed, signals, and a bounded
// wait for its exit. Never a sleep as synchronisation: a test waits for what the process wrote
// (wait_for_text) or for its exit.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

extern char** environ;

namespace dualv::test {

inline std::string read_text_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// `BINARY ARGS` run to its end through the shell (stdout and stderr together): the one-shot
// CLI tests (exit code and everything printed).
struct CliResult {
  int exit_code = -1;  // -1: not started, or ended by a signal
  std::string output;
};
inline CliResult run_cli(const std::string& binary, const std::string& args) {
  CliResult r;
  FILE* p = popen((binary + " " + args + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  while (fgets(buf, sizeof buf, p) != nullptr) r.output += buf;
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

class DualvProcess {
 public:
  using Clock = std::chrono::steady_clock;
  struct Env {
    std::vector<std::pair<std::string, std::string>> set;  // NAME, value
    std::vector<std::string> unset;                        // NAME (also every NAME_* prefix)
  };

  DualvProcess(const std::string& binary, std::vector<std::string> args,
               const std::filesystem::path& log, const Env& env = {})
      : log_(log) {
    args.insert(args.begin(), binary);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> vars;
    for (char** e = environ; *e; ++e) {
      const std::string v = *e;
      bool keep = true;
      for (const auto& name : env.unset)
        if (v.rfind(name + "=", 0) == 0 || v.rfind(name + "_", 0) == 0) keep = false;
      for (const auto& [name, value] : env.set)
        if (v.rfind(name + "=", 0) == 0) keep = false;
      if (keep) vars.push_back(v);
    }
    for (const auto& [name, value] : env.set) vars.push_back(name + "=" + value);
    std::vector<char*> envp;
    for (auto& v : vars) envp.push_back(v.data());
    envp.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    if (posix_spawn(&pid_, binary.c_str(), &actions, nullptr, argv.data(), envp.data()) != 0)
      pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~DualvProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  DualvProcess(const DualvProcess&) = delete;
  DualvProcess& operator=(const DualvProcess&) = delete;

  bool started() const { return pid_ > 0; }
  void signal(int sig) const {
    if (pid_ > 0) kill(pid_, sig);
  }
  // Exit status (128 + signal when killed by one), or -1 when it did not end within `within`.
  int wait(std::chrono::milliseconds within) {
    const auto end = Clock::now() + within;
    while (!reaped() && Clock::now() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return pid_ > 0 ? -1 : exit_status_;
  }
  // True as soon as the output holds `text`; false after `within` or when the process ended
  // without writing it.
  bool wait_for_text(const std::string& text, std::chrono::milliseconds within) {
    return wait_for_any_text({text}, within) == 0;
  }
  // The index of the first of `texts` found in the output, -1 when none came within `within`
  // (or the process ended without writing any).
  int wait_for_any_text(const std::vector<std::string>& texts, std::chrono::milliseconds within) {
    const auto end = Clock::now() + within;
    for (;;) {
      const bool ended = reaped();  // before reading: what it wrote before it ended is seen
      const std::string out = output();
      for (std::size_t i = 0; i < texts.size(); ++i)
        if (out.find(texts[i]) != std::string::npos) return static_cast<int>(i);
      if (ended || Clock::now() >= end) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  std::string output() const { return read_text_file(log_); }

 private:
  // True once the process has ended (its status in exit_status_).
  bool reaped() {
    if (pid_ <= 0) return true;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) != pid_) return false;
    pid_ = -1;
    exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return true;
  }
  std::filesystem::path log_;
  pid_t pid_ = -1;
  int exit_status_ = -1;
};

}  // namespace dualv::test
