#include "runtime/replay_state.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace dualv::runtime {

namespace {

constexpr const char* kHeader = "dualv-replay-state 1";

std::string to_hex(const std::string& s) {
  std::string out;
  for (unsigned char c : s) out += fmt::format("{:02x}", c);
  return out;
}

bool from_hex(const std::string& hex, std::string& out) {
  if (hex.size() % 2 != 0 || hex.size() > 256) return false;
  out.clear();
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    unsigned v = 0;
    for (std::size_t k = 0; k < 2; ++k) {
      const char c = hex[i + k];
      const int d = (c >= '0' && c <= '9') ? c - '0' : (c >= 'a' && c <= 'f') ? c - 'a' + 10 : -1;
      if (d < 0) return false;
      v = v * 16 + static_cast<unsigned>(d);
    }
    out += static_cast<char>(v);
  }
  return true;
}

bool write_all(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

LoadedReplayState load_replay_state(const std::string& path) {
  LoadedReplayState out;
  std::ifstream in(path);
  if (!in) {
    out.status = ReplayStateStatus::kMissing;
    out.message = fmt::format("replay state {}: missing ({})", path, std::strerror(errno));
    return out;
  }
  auto corrupt = [&](const std::string& why) {
    out.status = ReplayStateStatus::kCorrupt;
    out.marks = {};
    out.message = fmt::format("replay state {}: corrupt ({})", path, why);
    return out;
  };
  std::string line;
  if (!std::getline(in, line) || line != kHeader) return corrupt("no header line");
  std::size_t count = 0;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string kind, hex, extra;
    if (!(fields >> kind)) return corrupt("empty line");
    if (kind == "end") {
      std::size_t n = 0;
      if (!(fields >> n) || (fields >> extra) || n != count)
        return corrupt(fmt::format("end line does not match {} marks", count));
      if (std::getline(in, line)) return corrupt("text after the end line");
      out.status = ReplayStateStatus::kLoaded;
      out.message = fmt::format("replay state {}: {} marks loaded", path, count);
      return out;
    }
    std::int64_t seq = 0;
    std::string key;
    if (!(fields >> hex >> seq) || (fields >> extra) || !from_hex(hex, key))
      return corrupt(fmt::format("bad line '{}'", line.substr(0, 80)));
    if (kind == "command")
      out.marks.commands[key] = seq;
    else if (kind == "setpoint")
      out.marks.setpoints[key] = seq;
    else
      return corrupt(fmt::format("unknown mark kind '{}'", kind.substr(0, 20)));
    ++count;
  }
  return corrupt("no end line (file cut short)");
}

std::string save_replay_state(const std::string& path, const ReplayMarks& marks) {
  std::string text = std::string(kHeader) + "\n";
  std::size_t count = 0;
  for (const auto& [key, seq] : marks.commands) {
    text += fmt::format("command {} {}\n", to_hex(key), seq);
    ++count;
  }
  for (const auto& [key, seq] : marks.setpoints) {
    text += fmt::format("setpoint {} {}\n", to_hex(key), seq);
    ++count;
  }
  text += fmt::format("end {}\n", count);

  // One temporary file per process: two processes saving at once never write into the
  // same one (the last rename wins, each file whole).
  const std::string tmp = fmt::format("{}.tmp.{}", path, ::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return fmt::format("cannot create {}: {}", tmp, std::strerror(errno));
  const bool written = write_all(fd, text) && ::fsync(fd) == 0;
  const int saved_errno = errno;
  ::close(fd);
  if (!written) {
    ::unlink(tmp.c_str());
    return fmt::format("cannot write {}: {}", tmp, std::strerror(saved_errno));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    return fmt::format("cannot rename {} to {}: {}", tmp, path, std::strerror(e));
  }
  // The rename itself is durable only once the folder is synced.
  std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) dir = std::filesystem::path(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

std::string create_replay_state_on_first_use(const std::string& path) {
  namespace fs = std::filesystem;
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (fs::exists(dir, ec)) return {};
  fs::create_directories(dir, ec);
  if (ec)
    throw std::runtime_error(fmt::format("replay state {}: cannot create the folder {}: {}", path,
                                         dir.string(), ec.message()));
  fs::permissions(dir, fs::perms::owner_all, ec);  // the marks are the operators' business
  if (const std::string err = save_replay_state(path, {}); !err.empty())
    throw std::runtime_error(fmt::format("replay state {}: {}", path, err));
  return fmt::format("replay state {}: created empty (first use: its folder did not exist)", path);
}

}  // namespace dualv::runtime
