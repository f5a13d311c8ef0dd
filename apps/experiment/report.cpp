#include "apps/experiment/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#ifndef DUALV_SCRIPTS_DIR
#define DUALV_SCRIPTS_DIR "/usr/share/dualv"
#endif

namespace dualv::apps {

std::string scripts_dir() {
  if (const char* env = std::getenv("DUALV_SCRIPTS_DIR")) return env;
  return DUALV_SCRIPTS_DIR;
}

namespace {

std::string metrics_line(const std::string& run, const SegmentMetrics& m, int n) {
  std::string peaks;
  for (int i = 0; i < n; ++i) peaks += fmt::format("{:6.2f}", m.peak_tau[i]);
  return fmt::format("{:<24} {:<10} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {} {:>8.3f} {:>10.3g}\n",
                     run, m.label, m.max_error_x_mm, m.max_error_y_mm, m.max_error_mm,
                     m.rms_error_mm, peaks, m.max_tau_step, m.rms_internal);
}

}  // namespace

std::string summary_table(const std::vector<RunResult>& runs) {
  if (runs.empty()) return "";
  const int n = runs.front().n;
  std::string peaks_head;
  for (int i = 0; i < n; ++i) peaks_head += fmt::format(" tau{}", i + 1) + " ";
  std::string out =
      fmt::format("{:<24} {:<10} {:>7} {:>7} {:>7} {:>7} {}{:>8} {:>10}\n", "run", "shape",
                  "max|ex|", "max|ey|", "max|e|", "rms|e|", peaks_head, "max dtau", "rms tau_N");
  out += fmt::format("{:<24} {:<10} {:>7} {:>7} {:>7} {:>7} {:<{}}{:>8} {:>10}\n", "", "", "mm",
                     "mm", "mm", "mm", " peak |tau| N m", peaks_head.size(), "N m", "N m");
  for (const auto& r : runs) {
    if (!r.ok) out += fmt::format("{:<24} FAILED: {}\n", r.variant.name, r.failure);
    for (const auto& m : r.segments)
      if (m.kind == trajectory::SegmentKind::kShape) out += metrics_line(r.variant.name, m, n);
    out += metrics_line(r.variant.name, r.shapes, n);
    out += metrics_line(r.variant.name, r.program, n);
  }
  out += fmt::format(
      "(a shape's row covers its own window only; `program` is every cycle of the run, with the "
      "moves, dwells and the ringing after each shape)\n");
  for (const auto& r : runs)
    if (r.program.cycles > 0)
      out += fmt::format(
          "{}: whole program max |ex| {:.3f} mm at t = {:.3f} s, max |ey| {:.3f} mm at t = {:.3f} "
          "s, max |e| {:.3f} mm at t = {:.3f} s\n",
          r.variant.name, r.program.max_error_x_mm, r.program.t_max_error_x,
          r.program.max_error_y_mm, r.program.t_max_error_y, r.program.max_error_mm,
          r.program.t_max_error);
  const RunResult* retimed = nullptr;
  const RunResult* original = nullptr;
  for (const auto& r : runs) {
    if (r.variant.name == "retimed") retimed = &r;
    if (r.variant.name == "original") original = &r;
  }
  if (retimed && original) {
    out += fmt::format(
        "\nretimed vs original clock (all shapes): max error {:.3f} vs {:.3f} mm, largest torque "
        "step {:.2f} vs {:.2f} N m, peak torque {:.2f} vs {:.2f} N m\n",
        retimed->shapes.max_error_mm, original->shapes.max_error_mm, retimed->shapes.max_tau_step,
        original->shapes.max_tau_step,
        *std::max_element(retimed->shapes.peak_tau.begin(), retimed->shapes.peak_tau.begin() + n),
        *std::max_element(original->shapes.peak_tau.begin(),
                          original->shapes.peak_tau.begin() + n));
    out += fmt::format(
        "retimed vs original clock (whole program): max error {:.3f} vs {:.3f} mm, largest "
        "torque step {:.2f} vs {:.2f} N m\n",
        retimed->program.max_error_mm, original->program.max_error_mm,
        retimed->program.max_tau_step, original->program.max_tau_step);
  }
  return out;
}

void write_run_csv(const std::string& file, const RunResult& r) {
  std::FILE* f = std::fopen(file.c_str(), "w");
  if (!f) throw std::runtime_error(fmt::format("cannot write {}", file));
  std::string head = "t,segment,x_d,y_d,theta_d,x,y,theta,ex_mm,ey_mm";
  for (int i = 0; i < r.n; ++i) head += fmt::format(",tau{}", i + 1);
  head += ",tau_internal,plant_internal,lambda,lambda_dot,lambda_dd\n";
  std::fputs(head.c_str(), f);
  for (const Row& w : r.rows) {
    std::string line =
        fmt::format("{:.6f},{},{:.9f},{:.9f},{:.9f},{:.9f},{:.9f},{:.9f},{:.6f},{:.6f}", w.t,
                    w.segment, w.X_d.x(), w.X_d.y(), w.X_d.z(), w.X.x(), w.X.y(), w.X.z(),
                    (w.X_d.x() - w.X.x()) * 1e3, (w.X_d.y() - w.X.y()) * 1e3);
    for (int i = 0; i < r.n; ++i) line += fmt::format(",{:.6f}", w.tau[i]);
    line += fmt::format(",{:.6g},{:.6g},{:.9f},{:.9f},{:.9f}\n", w.tau_internal, w.plant_internal,
                        w.lambda, w.lambda_dot, w.lambda_dd);
    std::fputs(line.c_str(), f);
  }
  if (std::fclose(f) != 0) throw std::runtime_error(fmt::format("cannot write {}", file));
}

void write_csv(const std::string& dir, const std::vector<RunResult>& runs) {
  for (const auto& r : runs) write_run_csv(dir + "/" + r.variant.name + ".csv", r);
  const std::string file = dir + "/summary.csv";
  std::ofstream f(file);
  if (!f) throw std::runtime_error(fmt::format("cannot write {}", file));
  f << "run,segment,shape,max_ex_mm,max_ey_mm,max_e_mm,rms_e_mm,max_tau_step,rms_internal";
  const int n = runs.empty() ? 0 : runs.front().n;
  for (int i = 0; i < n; ++i) f << ",peak_tau" << i + 1;
  f << "\n";
  for (const auto& r : runs) {
    auto put = [&](const SegmentMetrics& m, const std::string& seg) {
      f << fmt::format("{},{},{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6g}", r.variant.name, seg,
                       m.label, m.max_error_x_mm, m.max_error_y_mm, m.max_error_mm, m.rms_error_mm,
                       m.max_tau_step, m.rms_internal);
      for (int i = 0; i < n; ++i) f << fmt::format(",{:.6f}", m.peak_tau[i]);
      f << "\n";
    };
    for (const auto& m : r.segments)
      if (m.kind == trajectory::SegmentKind::kShape) put(m, std::to_string(m.segment));
    put(r.shapes, "all");
    put(r.program, "program");
  }
  if (!f) throw std::runtime_error(fmt::format("cannot write {}", file));
}

std::string draw_plots(const std::string& dir) {
  const std::string script = scripts_dir() + "/plot_run.py";
  if (std::FILE* probe = std::fopen(script.c_str(), "r")) {
    std::fclose(probe);
  } else {
    return fmt::format("plot script {} not found", script);
  }
  // Debian's python3 sees python3-matplotlib; a python3 earlier on PATH may not.
  const char* py = std::getenv("DUALV_PYTHON");
  const std::string python = py ? py : "/usr/bin/python3";
  const std::string cmd = fmt::format("'{}' '{}' '{}' 2>&1", python, script, dir);
  std::FILE* p = popen(cmd.c_str(), "r");
  if (!p) return "cannot start " + python;
  std::string output;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p)) output += buf;
  const int status = pclose(p);
  if (status != 0) return fmt::format("plot script failed: {}", output);
  return "";
}

std::string bus_report(const drivers::CanopenActuatorSet& set, std::int64_t syncs_before) {
  const drivers::CanopenCounters& c = set.counters();
  std::string out = fmt::format("bus: {} SYNCs sent", c.sync_sent);
  if (syncs_before >= 0) out += fmt::format(" ({} before the program: priming)", syncs_before);
  out += fmt::format(
      ", ENOBUFS {}, send errors {}, bus-off {}; received: foreign SYNCs {}, unknown frames {}, "
      "malformed frames {}, ignored frames {}\n",
      c.tx_would_block, c.tx_errors, c.bus_off, c.foreign_sync, c.unknown_frames,
      c.malformed_frames, c.ignored_frames);
  for (int i = 0; i < set.size(); ++i) {
    const drivers::DriveCounters& d = set.drive_counters(i);
    out += fmt::format(
        "  {}; TPDOs {}, missed {}, late {}, duplicate {}, out of order {}, malformed {}, "
        "EMCYs {}, heartbeat timeouts {}, boot-ups {}\n",
        drivers::describe(set.health(i)), d.tpdos, d.missed, d.late, d.duplicates, d.out_of_order,
        d.malformed, d.emcys, d.heartbeat_timeouts, d.boot_ups);
  }
  return out;
}

}  // namespace dualv::apps
