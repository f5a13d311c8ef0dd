// `dualv identify`: dynamic parameter identification (issue 16, docs/identification.md). Runs
// the excitation (control/identification/excitation.hpp) on the in-process simulation, or reads
// a logged run (--log: a CSV of `dualv run` or an LCM log), identifies the base parameters by
// weighted least squares and writes: a complete configuration copy with the identified model
// (loadable with -c), a report table (nominal, identified, sigma, relative change) and the
// measured vs predicted torques of a validation run (CSV).
#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "apps/experiment/closed_loop.hpp"
#include "apps/experiment/report.hpp"
#include "apps/experiment/robot_config.hpp"
#include "apps/identify/identify_config.hpp"
#include "apps/identify/recording_io.hpp"
#include "common/yaml_reader.hpp"
#include "control/identification/excitation.hpp"
#include "control/identification/identify.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::apps {

namespace {

using namespace identification;

std::string default_identify_file() { return default_config_dir() + "/identify.yaml"; }

struct IdentifyArgs {
  std::string config;
  std::string log;
  std::string out;
  std::string validation_program;
  std::string identify_config;
  double cutoff_hz = 0.0;
  int decimation = 0;
  double torque_delay = -1.0;
};

std::string timestamp() {
  const std::time_t now = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", std::localtime(&now));
  return buf;
}

std::string report_table(const Identification& id) {
  std::string s = fmt::format("{:<14} {:>12} {:>12} {:>10} {:>9}  {}\n", "base parameter",
                              "nominal", "identified", "sigma", "change", "meaning");
  for (int j = 0; j < id.base.size(); ++j) {
    const double nom = id.nominal[j], val = id.estimate.phi[j];
    const std::string change =
        std::abs(nom) > 1e-12 ? fmt::format("{:+.1f} %", 100.0 * (val - nom) / std::abs(nom)) : "-";
    s += fmt::format("{:<14} {:>12.5g} {:>12.5g} {:>10.2g} {:>9}  {} [{}]\n", id.base.name(j), nom,
                     val, id.estimate.sigma[j], change, id.base.meaning(j), id.base.unit(j));
  }
  s += fmt::format(
      "condition number {:.1f} (scaled, weighted regressor), {} equations, torque noise {:.3g} "
      "N m, {:.2f} s of samples\n",
      id.estimate.condition, id.estimate.rows, id.estimate.torque_noise, id.duration);
  s += fmt::format(
      "estimator: {}; sigma from the residuals' correlation over {:.3g} s (Newey-West, {:.2f} x "
      "the white-noise sigma on average)\n",
      id.estimate.instrumental ? "instrumental variables (the reference motion's regressor)"
                               : "weighted least squares (no reference in the recording)",
      id.correlation_time, id.estimate.correlation_factor);
  return s;
}

YAML::Node link_node(double length, const model::Body& b) {
  YAML::Node n;
  n["length"] = length;
  n["mass"] = b.mass;
  n["inertia"] = b.inertia;
  n["com"].push_back(b.com.x());
  n["com"].push_back(b.com.y());
  n["com"].SetStyle(YAML::EmitterStyle::Flow);
  return n;
}

// The configuration file with its model's bodies replaced by `identified` (per chain).
void write_identified_config(const std::string& config_path, const model::Model& identified,
                             const std::string& out_path) {
  YAML::Node root = YAML::LoadFile(config_path);
  YAML::Node m = root["model"];
  for (int i = 0; i < identified.n; ++i) {
    const model::Chain& ch = identified.chains[i];
    m["chains"][i]["crank"] = link_node(ch.crank_length, ch.crank);
    m["chains"][i]["coupler"] = link_node(ch.coupler_length, ch.coupler);
  }
  m["plate"]["mass"] = identified.plate.mass;
  m["plate"]["inertia"] = identified.plate.inertia;
  YAML::Node com;
  com.push_back(identified.plate.com.x());
  com.push_back(identified.plate.com.y());
  com.SetStyle(YAML::EmitterStyle::Flow);
  m["plate"]["com"] = com;
  std::ofstream out(out_path);
  out << "# dualv configuration with the model identified by `dualv identify` from " << config_path
      << "\n"
      << root << "\n";
  if (!out) throw std::runtime_error(fmt::format("cannot write {}", out_path));
}

void write_torques(const std::string& path, const TorqueComparison& c) {
  std::ofstream out(path);
  const int n = c.measured.empty() ? 0 : static_cast<int>(c.measured.front().size());
  out << "t";
  for (int i = 1; i <= n; ++i) out << ",measured" << i << ",predicted" << i;
  out << "\n";
  for (std::size_t k = 0; k < c.t.size(); ++k) {
    out << fmt::format("{:.6f}", c.t[k]);
    for (int i = 0; i < n; ++i)
      out << fmt::format(",{:.6f},{:.6f}", c.measured[k][i], c.predicted[k][i]);
    out << "\n";
  }
  if (!out) throw std::runtime_error(fmt::format("cannot write {}", path));
}

// The paper program tracked by the proposed controller with the nominal (mismatched) model and
// with the identified one, on the same simulated machine: max and RMS error per shape.
std::string tracking_comparison(const RobotConfig& nominal_cfg, const model::Model& identified,
                                const trajectory::Program& program) {
  RobotConfig identified_cfg = nominal_cfg;
  identified_cfg.model = identified;
  identified_cfg.plant.true_model = sim::make_true_model(nominal_cfg.model, nominal_cfg.plant);
  Variant v;
  v.name = "retimed";
  const RunResult a = run_in_process(nominal_cfg, program, v);
  const RunResult b = run_in_process(identified_cfg, program, v);
  std::string s = fmt::format("{:<10} {:>13} {:>13} {:>13} {:>13}\n", "shape", "max nominal",
                              "max identified", "RMS nominal", "RMS identified");
  auto row = [&](const SegmentMetrics& x, const SegmentMetrics& y, const std::string& label) {
    s += fmt::format("{:<10} {:>10.4f} mm {:>10.4f} mm {:>10.4f} mm {:>10.4f} mm\n", label,
                     x.max_error_mm, y.max_error_mm, x.rms_error_mm, y.rms_error_mm);
  };
  for (std::size_t k = 0; k < a.segments.size() && k < b.segments.size(); ++k)
    if (a.segments[k].kind == trajectory::SegmentKind::kShape)
      row(a.segments[k], b.segments[k], a.segments[k].label);
  row(a.shapes, b.shapes, "all");
  if (!a.ok || !b.ok) s += fmt::format("(a run stopped early: {}{})\n", a.failure, b.failure);
  return s;
}

// scripts/plot_identification.py on `dir` with Debian's python (DUALV_PYTHON overrides): "" on
// success, else why there is no PNG.
std::string plot_validation(const std::string& dir) {
  const std::string script = scripts_dir() + "/plot_identification.py";
  if (!std::filesystem::exists(script)) return fmt::format("plot script {} not found", script);
  const char* py = std::getenv("DUALV_PYTHON");
  const std::string cmd =
      fmt::format("'{}' '{}' '{}' 2>&1", py ? py : "/usr/bin/python3", script, dir);
  std::FILE* p = popen(cmd.c_str(), "r");
  if (!p) return "cannot start python";
  std::string output;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p)) output += buf;
  return pclose(p) == 0 ? "" : "plot script failed: " + output;
}

int run_identify(const IdentifyArgs& args) {
  const std::string config_path = resolve_config(args.config);
  const RobotConfig cfg = load_robot_config(config_path);
  const BaseParameters base = find_base_parameters(cfg.model);
  // Like every default of `dualv` (apps/config_path.hpp), identify.yaml and the validation
  // program come from the default config folder (/etc/dualv when installed), not from the
  // folder of a -c file. The shipped identify.yaml is complete: it is required.
  const std::string identify_path =
      args.identify_config.empty() ? default_identify_file() : args.identify_config;
  const IdentifyConfig icfg = load_identify_config(identify_path);
  IdentifyOptions options = icfg.estimation;
  options.torque_delay = args.torque_delay >= 0.0 ? args.torque_delay
                         : icfg.torque_delay      ? *icfg.torque_delay
                                                  : drive_latency(cfg);
  if (args.cutoff_hz > 0.0) options.cutoff_hz = args.cutoff_hz;
  if (args.decimation > 0) options.decimation = args.decimation;
  // The nominal friction: the plant section's (the model itself has no friction).
  const JointFriction friction{cfg.plant.friction.viscous, cfg.plant.friction.coulomb};
  Recording rec;
  if (!args.log.empty()) {
    rec = read_recording(args.log);
    fmt::print("identify: {} samples at {:.0f} Hz from {}\n", rec.size(), 1.0 / rec.period,
               args.log);
  } else {
    const Excitation ex =
        design_excitation(cfg.model, base, cfg.trajectory.limits, icfg.excitation);
    fmt::print(
        "identify: excitation {:.1f} s (Fourier series, {} base parameters), regressor condition "
        "number {:.1f}; running it on the in-process simulation\n",
        ex.program.duration(), base.size(), ex.condition);
    Variant v;
    v.name = "excitation";
    const RobotConfig run_cfg = icfg.for_excitation_run(cfg);
    fmt::print("identify: excitation run with kp {:g}, kd {:g} (identify.run)\n",
               run_cfg.control.controller.kp[0], run_cfg.control.controller.kd[0]);
    const RunResult run = run_in_process(run_cfg, ex.program, v);
    if (!run.ok) fmt::print("identify: the excitation run stopped early: {}\n", run.failure);
    rec = recording_from_run(run, cfg.period());
  }
  Identification id;
  try {
    id = identify(cfg.model, standard_parameters(cfg.model, friction), rec, options);
  } catch (const IdentificationError& e) {
    fmt::print(stderr, "dualv identify: refused: {}\n", e.what());
    return 3;
  }
  const std::string table = report_table(id);
  fmt::print("{}", table);
  const std::string dir = args.out.empty() ? "out/identify-" + timestamp() : args.out;
  std::filesystem::create_directories(dir);
  {
    std::ofstream f(dir + "/report.txt");
    f << table;
  }
  const Eigen::VectorXd phi =
      id.base.to_standard(id.estimate.phi, standard_parameters(cfg.model, friction));
  const model::Model identified = model_with_parameters(cfg.model, phi);
  write_identified_config(config_path, identified, dir + "/identified.yaml");
  // Validation: the paper program (a motion the identification never saw) with the nominal
  // model, its torques against the identified model's prediction.
  if (args.log.empty()) {
    trajectory::ProgramContext ctx;
    ctx.start = cfg.model.home;
    ctx.home = cfg.model.home;
    const std::string program_file = resolve_program(args.validation_program);
    const trajectory::Program program = trajectory::load_program_file(program_file, ctx);
    Variant v;
    v.name = "validation";
    const RunResult run = run_in_process(cfg, program, v);
    const Recording val = recording_from_run(run, cfg.period());
    const TorqueComparison c = compare_torques(cfg.model, id.base, id.estimate.phi, val, options);
    const TorqueComparison cn = compare_torques(cfg.model, id.base, id.nominal, val, options);
    write_torques(dir + "/validation_torques.csv", c);
    const std::string comparison = tracking_comparison(cfg, identified, program);
    fmt::print(
        "paper program, proposed controller, nominal vs identified model (same simulated "
        "machine):\n{}",
        comparison);
    std::ofstream(dir + "/tracking.txt") << comparison;
    if (const std::string why = plot_validation(dir); !why.empty())
      fmt::print("identify: no validation.png: {}\n", why);
    fmt::print(
        "validation ({}): RMS torque {:.3f} N m; prediction error RMS {:.4f} N m with the "
        "identified model, {:.4f} N m with the nominal one\n",
        program_file, c.rms_measured, c.rms_error, cn.rms_error);
  }
  if (!args.log.empty()) {
    // No second run to validate on: the prediction along the log itself.
    const TorqueComparison c = compare_torques(cfg.model, id.base, id.estimate.phi, rec, options);
    const TorqueComparison cn = compare_torques(cfg.model, id.base, id.nominal, rec, options);
    write_torques(dir + "/validation_torques.csv", c);
    fmt::print(
        "prediction along the log (the identification data): RMS torque {:.3f} N m; error RMS "
        "{:.4f} N m with the identified model, {:.4f} N m with the nominal one\n",
        c.rms_measured, c.rms_error, cn.rms_error);
    if (const std::string why = plot_validation(dir); !why.empty())
      fmt::print("identify: no validation.png: {}\n", why);
  }
  fmt::print("identify: wrote {}/report.txt, identified.yaml (use with -c){}\n", dir,
             args.log.empty() ? ", validation_torques.csv, validation.png, tracking.txt"
                              : ", validation_torques.csv, validation.png");
  return 0;
}

}  // namespace

void register_identify_command(CLI::App& app) {
  auto args = std::make_shared<IdentifyArgs>();
  CLI::App* cmd = app.add_subcommand(
      "identify",
      "Identify the robot's dynamic parameters (base parameters, friction) by an "
      "excitation run or from a logged run");
  add_config_option(*cmd, args->config);
  cmd->add_option("--log", args->log, "Identify from a logged run: CSV of `dualv run` or .lcmlog");
  cmd->add_option("--out", args->out, "Output folder (default out/identify-<date>-<time>)");
  cmd->add_option("--validate", args->validation_program,
                  "Program for the validation run (default: " + default_program_file() + ")");
  cmd->add_option("--identify-config", args->identify_config,
                  "Excitation, estimation and excitation-run gain settings (default: " +
                      default_identify_file() + ")");
  cmd->add_option("--cutoff", args->cutoff_hz, "Zero-phase low-pass cutoff [Hz] (default 50)");
  cmd->add_option("--decimation", args->decimation, "Keep every k-th filtered sample (default 4)");
  cmd->add_option("--torque-delay", args->torque_delay,
                  "Latency from torque sent to torque acting [s] (default: from the plant section: "
                  "(transport cycles + 0.5) / rate + current-loop time constant)");
  cmd->callback([args] { exit_code() = run_identify(*args); });
}

}  // namespace dualv::apps
