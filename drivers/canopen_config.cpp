#include "drivers/canopen_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common/yaml_reader.hpp"
#include "firmware_if/units.hpp"

namespace dualv::drivers {

namespace {

constexpr double kNsPerS = 1e9;

std::uint64_t to_ns(double s) {
  return s > 0.0 ? static_cast<std::uint64_t>(std::llround(s * kNsPerS)) : 0;
}
double to_s(std::uint64_t ns) { return static_cast<double>(ns) / kNsPerS; }
bool whole_ms(std::uint64_t ns) { return ns % 1'000'000 == 0; }

// can.drives[i].max_torque against the drive's peak and the safety clamp.
void check_torque(const CanConfig& c, double safety_max, std::vector<std::string>& p) {
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const CanDriveConfig& d = c.drives[i];
    if (!(d.max_torque > 0.0) || !(d.rated_torque > 0.0) || !(d.peak_torque > 0.0)) continue;
    // Compared as 6072h would carry them: per mille of the rated torque 6076h.
    const std::uint16_t max_pm = fw::max_torque_per_mille(d.max_torque, d.rated_torque);
    const std::uint16_t peak_pm = fw::max_torque_per_mille(d.peak_torque, d.rated_torque);
    if (max_pm > peak_pm)
      p.push_back(fmt::format(
          "can.drives[{}].max_torque: {} N m (6072h = {} per mille of 6076h = {} N m) is above "
          "the drive's peak can.drives[{}].peak_torque = {} N m ({} per mille)",
          i, d.max_torque, max_pm, d.rated_torque, i, d.peak_torque, peak_pm));
    if (safety_max > 0.0 && d.max_torque > safety_max)
      p.push_back(fmt::format(
          "can.drives[{}].max_torque: {} N m is above the safety limit safety.torque.max = {} N m: "
          "the drive would allow more than the safety layer ever commands",
          i, d.max_torque, safety_max));
  }
}

// The safety consequences of skipping objects (drivers/canopen/README.md "Boot objects"):
// a drive that may lack 6007h must watch the host through its heartbeat consumer 1016h (or
// nothing would stop it when the host dies in a way 6007h's default does not cover); a
// drive that may lack 1016h must have 6007h and the RPDO deadline (1400h sub5).
void check_objects(const BootObjects& o, const std::string& key, const CanConfig& c,
                   std::vector<std::string>& p) {
  if (o.abort_connection != ObjectPolicy::kRequired &&
      o.consumer_heartbeat != ObjectPolicy::kRequired)
    p.push_back(fmt::format(
        "{}.consumer_heartbeat: must be required when {}.abort_connection is {}: without 6007h "
        "the drive's heartbeat consumer of the host (1016h) is what stops it when the host is "
        "gone",
        key, key, to_string(o.abort_connection)));
  if (o.consumer_heartbeat != ObjectPolicy::kRequired && c.rpdo_deadline_ns == 0)
    p.push_back(fmt::format(
        "{}.consumer_heartbeat: {} needs can.rpdo_deadline > 0: without 1016h only the RPDO "
        "deadline (1400h sub5) stops the drive when the host is gone",
        key, to_string(o.consumer_heartbeat)));
}

// The semantic rules, on the parsed values; one message per broken rule, naming the key.
void check(const CanConfig& c, std::vector<std::string>& p) {
  auto add = [&p](std::string m) { p.push_back(std::move(m)); };
  if (c.interface.empty()) add("can.interface: must not be empty (e.g. can0 or vcan0)");
  if (c.bitrate < 10'000 || c.bitrate > 1'000'000)
    add(fmt::format("can.bitrate: must be in [10000, 1000000] bit/s (got {})", c.bitrate));
  if (!(c.max_bus_load > 0.0 && c.max_bus_load <= 1.0))
    add(fmt::format("can.max_bus_load: must be in (0, 1] (got {})", c.max_bus_load));
  // CAN FD data phase: at least the nominal rate, at most 8 Mbit/s (the fastest CAN FD
  // transceivers, ISO 11898-2:2016 with CiA 601-4 signal improvement).
  if (c.data_bitrate < c.bitrate || c.data_bitrate > 8'000'000)
    add(fmt::format("can.fd.data_bitrate: must be in [can.bitrate = {}, 8000000] bit/s (got {})",
                    c.bitrate, c.data_bitrate));
  if (c.bus_layout == fw::BusLayout::kFd && c.drives.size() > fw::kFdMaxDrives)
    add(fmt::format("can.bus_layout: fd carries at most {} drives in one FD RPDO (got {})",
                    fw::kFdMaxDrives, c.drives.size()));
  if (c.bus_layout == fw::BusLayout::kBroadcast && c.drives.size() > fw::kBroadcastMaxDrives)
    add(fmt::format("can.bus_layout: broadcast carries at most {} drives in one frame (got {})",
                    fw::kBroadcastMaxDrives, c.drives.size()));
  if (!(c.max_cyclic_load > 0.0 && c.max_cyclic_load <= c.max_bus_load))
    add(fmt::format("can.max_cyclic_load: must be in (0, can.max_bus_load = {}] (got {})",
                    c.max_bus_load, c.max_cyclic_load));
  if (c.controlword_refresh_ns == 0) add("can.controlword_refresh: must be > 0");
  if (c.controlword_inhibit_ns == 0 || c.controlword_inhibit_ns > c.controlword_refresh_ns)
    add(
        fmt::format("can.controlword_inhibit: must be in (0, can.controlword_refresh = {} s] (got "
                    "{} s)",
                    to_s(c.controlword_refresh_ns), to_s(c.controlword_inhibit_ns)));
  // 1802h sub3 is in 100 us units (u16), sub5 in ms (u16) (CiA 301 7.5.2.37).
  if (c.statusword_inhibit_ns == 0 || c.statusword_inhibit_ns % 100'000 != 0 ||
      c.statusword_inhibit_ns > 6'553'500'000ull)
    add(
        fmt::format("can.statusword_inhibit: must be a multiple of 0.0001 s in [0.0001, 6.5535] s "
                    "(1800h sub3 is in 100 us) (got {} s)",
                    to_s(c.statusword_inhibit_ns)));
  if (c.statusword_refresh_ns == 0 || !whole_ms(c.statusword_refresh_ns) ||
      c.statusword_refresh_ns > 65'535'000'000ull ||
      c.statusword_refresh_ns < c.statusword_inhibit_ns)
    add(
        fmt::format("can.statusword_refresh: must be whole milliseconds in [can.statusword_inhibit "
                    "= {} s, 65.535] s (got {} s)",
                    to_s(c.statusword_inhibit_ns), to_s(c.statusword_refresh_ns)));
  if (c.bus_layout == fw::BusLayout::kBroadcast &&
      c.transition_timeout_ns <=
          c.controlword_inhibit_ns + c.statusword_inhibit_ns + 2 * c.sync_period_ns)
    add(fmt::format(
        "can.timeouts.transition: {} s is too short for the broadcast layout: a CiA 402 "
        "step may take can.controlword_inhibit + can.statusword_inhibit + 2 cycles = "
        "{} s",
        to_s(c.transition_timeout_ns),
        to_s(c.controlword_inhibit_ns + c.statusword_inhibit_ns + 2 * c.sync_period_ns)));
  if (c.sync_period_ns < 100'000 || c.sync_period_ns > 1'000'000'000)
    add(fmt::format("can.sync.period: must be in [0.0001, 1] s (got {})", to_s(c.sync_period_ns)));
  if (c.sync_counter_overflow == 1 || c.sync_counter_overflow > fw::kSyncCounterOverflowMax)
    add(fmt::format("can.sync.counter_overflow: must be 0 (no counter) or 2..240 (got {})",
                    c.sync_counter_overflow));
  if (!fw::is_valid_node_id(c.master_node_id))
    add(fmt::format("can.master.node_id: must be in 1..127 (got {})", c.master_node_id));
  if (c.master_heartbeat_period_ns == 0) add("can.master.heartbeat_period: must be > 0");
  auto od_ms = [&](std::uint64_t ns, const char* key, bool zero_ok) {
    if (ns == 0 && zero_ok) return;
    if (ns == 0 || !whole_ms(ns) || ns > 65'535'000'000ull)
      add(fmt::format("{}: must be whole milliseconds in [0.001, 65.535] s{} (got {})", key,
                      zero_ok ? " or 0" : "", to_s(ns)));
  };
  od_ms(c.drive_heartbeat_period_ns, "can.heartbeat.drive_period", false);
  od_ms(c.master_heartbeat_timeout_ns, "can.heartbeat.master_timeout", false);
  od_ms(c.rpdo_deadline_ns, "can.rpdo_deadline", true);
  od_ms(c.digital_inputs_refresh_ns, "can.digital_inputs_refresh", true);
  if (c.drive_heartbeat_timeout_ns <= c.drive_heartbeat_period_ns)
    add(
        fmt::format("can.heartbeat.drive_timeout: must be longer than can.heartbeat.drive_period "
                    "({} s <= {} s)",
                    to_s(c.drive_heartbeat_timeout_ns), to_s(c.drive_heartbeat_period_ns)));
  if (c.master_heartbeat_timeout_ns <= c.master_heartbeat_period_ns)
    add(
        fmt::format("can.heartbeat.master_timeout: must be longer than can.master.heartbeat_period "
                    "({} s <= {} s): the drives would stop while the host is alive",
                    to_s(c.master_heartbeat_timeout_ns), to_s(c.master_heartbeat_period_ns)));
  if (c.rpdo_deadline_ns != 0 && c.rpdo_deadline_ns <= c.sync_period_ns)
    add(fmt::format("can.rpdo_deadline: must be longer than can.sync.period ({} s <= {} s) or 0",
                    to_s(c.rpdo_deadline_ns), to_s(c.sync_period_ns)));
  if (c.sdo_timeout_ns == 0) add("can.timeouts.sdo: must be > 0");
  if (c.boot_timeout_ns == 0) add("can.timeouts.boot: must be > 0");
  if (c.transition_timeout_ns == 0) add("can.timeouts.transition: must be > 0");
  if (c.transition_timeout_ns != 0 && c.transition_timeout_ns < 2 * c.sync_period_ns)
    add(fmt::format("can.timeouts.transition: must be at least two SYNC periods ({} s)",
                    to_s(2 * c.sync_period_ns)));
  if (c.stale_cycles < 1) add("can.timeouts.stale_cycles: must be >= 1");
  const auto ac = static_cast<int>(c.abort_connection);
  if (ac < 0 || ac > 3) add(fmt::format("can.options.abort_connection: must be 0..3 (got {})", ac));
  const auto qs = static_cast<int>(c.quick_stop);
  if (qs < 0 || qs > 8) add(fmt::format("can.options.quick_stop: must be 0..8 (got {})", qs));
  const auto fr = static_cast<int>(c.fault_reaction);
  if (fr < 0 || fr > 4) add(fmt::format("can.options.fault_reaction: must be 0..4 (got {})", fr));

  if (c.drives.empty() || c.drives.size() > static_cast<std::size_t>(kMaxDrives))
    add(fmt::format("can.drives: must list 1..{} drives (got {})", kMaxDrives, c.drives.size()));
  for (std::size_t i = 0; i < c.drives.size(); ++i) {
    const CanDriveConfig& d = c.drives[i];
    const std::string k = fmt::format("can.drives[{}]", i);
    if (!fw::is_valid_node_id(d.node_id))
      add(fmt::format("{}.node_id: must be in 1..127 (got {})", k, d.node_id));
    for (std::size_t j = 0; j < i; ++j)
      if (c.drives[j].node_id == d.node_id)
        add(fmt::format("{}.node_id: {} is also can.drives[{}].node_id", k, d.node_id, j));
    if (d.node_id == c.master_node_id)
      add(fmt::format("{}.node_id: {} is the master's can.master.node_id", k, d.node_id));
    if (d.counts_per_revolution == 0) add(fmt::format("{}.counts_per_revolution: must be > 0", k));
    if (!(d.rated_torque > 0.0) || d.rated_torque * 1000.0 > 4.0e9)
      add(fmt::format("{}.rated_torque: must be > 0 N m (got {})", k, d.rated_torque));
    if (!(d.max_torque > 0.0))
      add(fmt::format("{}.max_torque: must be > 0 N m (got {})", k, d.max_torque));
    else if (d.rated_torque > 0.0 && d.max_torque * 1000.0 / d.rated_torque > 65535.0)
      add(fmt::format("{}.max_torque: {} N m is more than 65535 per mille of rated torque", k,
                      d.max_torque));
    if (!(d.peak_torque > 0.0))
      add(fmt::format("{}.peak_torque: must be > 0 N m (got {})", k, d.peak_torque));
    check_objects(d.objects, k + ".objects", c, p);
  }
  check_torque(c, 0.0, p);
}

ObjectPolicy read_policy(YamlReader& r, const std::string& key, ObjectPolicy fallback,
                         const std::string& path) {
  const std::string v = r.string(key, std::string(to_string(fallback)));
  if (v == "required") return ObjectPolicy::kRequired;
  if (v == "optional") return ObjectPolicy::kOptional;
  if (v == "off") return ObjectPolicy::kOff;
  r.problem(fmt::format("{}.{}: must be required, optional or off (got '{}')", path, key, v));
  return fallback;
}

BootObjects read_objects(YamlReader& parent, const BootObjects& fallback, const std::string& path) {
  BootObjects o = fallback;
  if (!parent.has("objects")) return o;
  YamlReader r = parent.child("objects");
  const std::string p = path + ".objects";
  o.cycle_period = read_policy(r, "cycle_period", o.cycle_period, p);
  o.interpolation_period = read_policy(r, "interpolation_period", o.interpolation_period, p);
  o.abort_connection = read_policy(r, "abort_connection", o.abort_connection, p);
  o.quick_stop = read_policy(r, "quick_stop", o.quick_stop, p);
  o.fault_reaction = read_policy(r, "fault_reaction", o.fault_reaction, p);
  o.consumer_heartbeat = read_policy(r, "consumer_heartbeat", o.consumer_heartbeat, p);
  o.digital_inputs = read_policy(r, "digital_inputs", o.digital_inputs, p);
  r.reject_unknown_keys();
  return o;
}

}  // namespace

CanConfig default_can_config() {
  CanConfig c;
  for (std::uint8_t id = 1; id <= 4; ++id)
    c.drives.push_back(CanDriveConfig{id, 1u << 20, 50.0, 60.0, 127.0, 0, BootObjects{}});
  return c;
}

CanConfig load_can_config(const YAML::Node& can_node, double safety_torque_max) {
  ConfigProblems problems;
  CanConfig c = default_can_config();
  YamlReader r(can_node, "can", problems.sink());
  if (!r.valid()) {
    problems.finish();
    return c;
  }
  c.interface = r.string("interface", c.interface);
  const double bitrate = r.number("bitrate", c.bitrate);
  c.bitrate = bitrate > 0 && bitrate < 4e9 ? static_cast<std::uint32_t>(bitrate) : 0;
  c.max_bus_load = r.number("max_bus_load", c.max_bus_load);
  if (r.has("rpdo_layout")) {
    // Renamed (issue 15): the key selects the TPDOs too.
    r.problem(
        "can.rpdo_layout: renamed can.bus_layout (per_drive | broadcast | fd: it selects the "
        "TPDOs and the frame format too); rename the key");
    (void)r.string("rpdo_layout");  // read, so not reported as unknown as well
  }
  const std::string layout = r.string("bus_layout", "per_drive");
  bool known_layout = false;
  for (fw::BusLayout l : fw::kBusLayouts)
    if (layout == fw::to_string(l)) {
      c.bus_layout = l;
      known_layout = true;
    }
  if (!known_layout)
    r.problem(fmt::format("can.bus_layout: must be per_drive, broadcast or fd (got '{}')", layout));
  {
    YamlReader f = r.child("fd", false);
    if (f.has("nominal_bitrate")) {  // one owner: can.bitrate
      f.problem(
          "can.fd.nominal_bitrate: the nominal (arbitration-phase) rate is can.bitrate, for "
          "classic and CAN FD frames alike; remove this key");
      (void)f.number("nominal_bitrate");
    }
    const double data = f.number("data_bitrate", c.data_bitrate);
    c.data_bitrate = data > 0 && data < 4e9 ? static_cast<std::uint32_t>(data) : 0;
    f.reject_unknown_keys();
  }
  c.max_cyclic_load = r.number("max_cyclic_load", c.max_cyclic_load);
  c.controlword_refresh_ns = to_ns(r.number("controlword_refresh", to_s(c.controlword_refresh_ns)));
  c.controlword_inhibit_ns = to_ns(r.number("controlword_inhibit", to_s(c.controlword_inhibit_ns)));
  c.statusword_inhibit_ns = to_ns(r.number("statusword_inhibit", to_s(c.statusword_inhibit_ns)));
  c.statusword_refresh_ns = to_ns(r.number("statusword_refresh", to_s(c.statusword_refresh_ns)));
  {
    YamlReader s = r.child("sync", false);
    c.sync_period_ns = to_ns(s.number("period", to_s(c.sync_period_ns)));
    const int ov = s.integer("counter_overflow", 0);
    c.sync_counter_overflow = ov >= 0 && ov <= 255 ? static_cast<std::uint8_t>(ov) : 255;
    s.reject_unknown_keys();
  }
  {
    YamlReader m = r.child("master", false);
    const int id = m.integer("node_id", c.master_node_id);
    c.master_node_id = id >= 0 && id <= 255 ? static_cast<std::uint8_t>(id) : 0;
    c.master_heartbeat_period_ns =
        to_ns(m.number("heartbeat_period", to_s(c.master_heartbeat_period_ns)));
    m.reject_unknown_keys();
  }
  {
    YamlReader h = r.child("heartbeat", false);
    c.drive_heartbeat_period_ns =
        to_ns(h.number("drive_period", to_s(c.drive_heartbeat_period_ns)));
    c.drive_heartbeat_timeout_ns =
        to_ns(h.number("drive_timeout", to_s(c.drive_heartbeat_timeout_ns)));
    c.master_heartbeat_timeout_ns =
        to_ns(h.number("master_timeout", to_s(c.master_heartbeat_timeout_ns)));
    h.reject_unknown_keys();
  }
  c.rpdo_deadline_ns = to_ns(r.non_negative("rpdo_deadline", to_s(c.rpdo_deadline_ns)));
  c.digital_inputs_refresh_ns =
      to_ns(r.non_negative("digital_inputs_refresh", to_s(c.digital_inputs_refresh_ns)));
  {
    YamlReader t = r.child("timeouts", false);
    c.sdo_timeout_ns = to_ns(t.number("sdo", to_s(c.sdo_timeout_ns)));
    c.boot_timeout_ns = to_ns(t.number("boot", to_s(c.boot_timeout_ns)));
    c.transition_timeout_ns = to_ns(t.number("transition", to_s(c.transition_timeout_ns)));
    const int stale = t.integer("stale_cycles", static_cast<int>(c.stale_cycles));
    c.stale_cycles = stale > 0 ? static_cast<std::uint32_t>(stale) : 0;
    t.reject_unknown_keys();
  }
  {
    YamlReader o = r.child("options", false);
    c.abort_connection = static_cast<fw::AbortConnectionOption>(
        o.integer("abort_connection", static_cast<int>(c.abort_connection)));
    c.quick_stop =
        static_cast<fw::QuickStopOption>(o.integer("quick_stop", static_cast<int>(c.quick_stop)));
    c.fault_reaction = static_cast<fw::FaultReactionOption>(
        o.integer("fault_reaction", static_cast<int>(c.fault_reaction)));
    o.reject_unknown_keys();
  }
  c.check_drive_parameters = r.boolean("check_drive_parameters", c.check_drive_parameters);
  {
    const std::string on_exit = r.string("on_exit", to_string(c.on_exit));
    if (on_exit == "preoperational")
      c.on_exit = OnExit::kPreOperational;
    else if (on_exit == "stopped")
      c.on_exit = OnExit::kStopped;
    else if (on_exit == "operational_disabled")
      c.on_exit = OnExit::kOperationalDisabled;
    else
      r.problem(fmt::format(
          "can.on_exit: must be preoperational, stopped or operational_disabled (got '{}')",
          on_exit));
  }
  const BootObjects objects = read_objects(r, BootObjects{}, "can");
  for (CanDriveConfig& d : c.drives) d.objects = objects;
  if (r.has("drives")) {
    c.drives.clear();
    std::size_t index = 0;
    for (YamlReader& d : r.children("drives")) {
      CanDriveConfig dc;
      dc.objects = read_objects(d, objects, fmt::format("can.drives[{}]", index++));
      const int id = d.integer("node_id");
      dc.node_id = id >= 0 && id <= 255 ? static_cast<std::uint8_t>(id) : 0;
      const int cpr =
          d.integer("counts_per_revolution", static_cast<int>(dc.counts_per_revolution));
      dc.counts_per_revolution = cpr > 0 ? static_cast<std::uint32_t>(cpr) : 0;
      dc.rated_torque = d.number("rated_torque", dc.rated_torque);
      dc.max_torque = d.number("max_torque", dc.max_torque);
      dc.peak_torque = d.number("peak_torque", dc.peak_torque);
      dc.zero_offset = d.integer("zero_offset", 0);
      d.reject_unknown_keys();
      c.drives.push_back(dc);
    }
  } else {
    r.children("drives", false);  // mark as read: absent means the default four drives
  }
  r.reject_unknown_keys();
  check(c, *problems.sink());
  if (safety_torque_max > 0.0) {
    std::vector<std::string> torque;
    check_torque(c, safety_torque_max, torque);
    // check() already named the peak problems: add only the safety ones.
    for (std::string& m : torque)
      if (m.find("safety.torque.max") != std::string::npos) problems.sink()->push_back(m);
  }
  problems.finish();
  return c;
}

double safety_torque_max_of(const YAML::Node& root) {
  constexpr double kSafetyDefault = 60.0;  // safety/safety_config.hpp torque.max
  const YAML::Node n = root["safety"];
  if (!n || !n.IsMap() || !n["torque"] || !n["torque"].IsMap() || !n["torque"]["max"])
    return kSafetyDefault;
  try {
    return n["torque"]["max"].as<double>();
  } catch (const YAML::Exception&) {
    return kSafetyDefault;  // the safety loader names the bad key
  }
}

CanConfig load_can_config_file(const std::string& path) {
  const YAML::Node root = YamlReader::load_file(path);
  return load_can_config(root["can"], safety_torque_max_of(root));
}

void check_torque_limits(const CanConfig& config, double safety_torque_max) {
  std::vector<std::string> p;
  check_torque(config, safety_torque_max, p);
  if (!p.empty()) throw ConfigError(p);
}

void validate(const CanConfig& config) {
  ConfigProblems problems;
  check(config, *problems.sink());
  problems.finish();
}

void check_sync_period(const CanConfig& config, double control_period_s) {
  const std::uint64_t control_ns = to_ns(control_period_s);
  if (control_ns != config.sync_period_ns)
    throw ConfigError({fmt::format(
        "can.sync.period: {} s but the control period is {} s (1 / loop.rate_hz): the SYNC is "
        "the control cycle, set them equal",
        to_s(config.sync_period_ns), control_period_s)});
}

fw::BusParams bus_params(const CanConfig& c) noexcept {
  fw::BusParams p;
  p.drives = static_cast<std::uint8_t>(c.drives.size());
  p.nominal_bitrate = c.bitrate;
  p.data_bitrate = c.data_bitrate;
  p.sync_bytes = c.sync_bytes();
  p.statusword_inhibit_s = to_s(c.statusword_inhibit_ns);
  p.controlword_inhibit_s = to_s(c.controlword_inhibit_ns);
  p.max_cyclic_load = c.max_cyclic_load;
  p.max_total_load = c.max_bus_load;
  return p;
}

fw::LayoutLoad bus_load_report(const CanConfig& config) noexcept {
  return fw::layout_load(config.bus_layout, bus_params(config), config.cycle_hz());
}

std::string format_bus_load(const CanConfig& config, const fw::LayoutLoad& r) {
  return fmt::format(
      "CAN bus load: {} drives, {} layout, SYNC {} B: {} bits/cycle worst case; at {:.1f} Hz and "
      "{} bit/s: {:.1f} % cyclic (limit {:.1f} %), {:.1f} % with event PDOs at their inhibit "
      "times (limit {:.1f} %); max rate {:.1f} Hz{}",
      config.drives.size(), fw::to_string(r.layout), config.sync_bytes(), r.cyclic_bits.total(),
      config.cycle_hz(),
      config.bus_layout == fw::BusLayout::kFd
          ? fmt::format("{} / {} (data phase)", config.bitrate, config.data_bitrate)
          : fmt::format("{}", config.bitrate),
      100.0 * r.cyclic_load, 100.0 * config.max_cyclic_load, 100.0 * r.total_load,
      100.0 * config.max_bus_load, r.max_rate_hz, r.fits ? "" : " -- DOES NOT FIT");
}

fw::LayoutLoad require_bus_load_fits(const CanConfig& config) {
  const fw::LayoutLoad r = bus_load_report(config);
  if (!r.fits) {
    // Classic: bits x rate against the bit rate; CAN FD: bus time, the arbitration phase at
    // can.bitrate and the data phase at can.fd.data_bitrate.
    const std::string demand =
        config.bus_layout == fw::BusLayout::kFd
            ? fmt::format(
                  "{:.1f} us of bus time a cycle worst case ({} bits at {} bit/s + {} "
                  "data-phase bits at can.fd.data_bitrate {} bit/s)",
                  1e6 * r.cycle_time_s, r.cyclic_bits.nominal, config.bitrate, r.cyclic_bits.data,
                  config.data_bitrate)
            : fmt::format("{:.0f} bit/s worst case ({} bits/cycle) on a {} bit/s bus",
                          static_cast<double>(r.cyclic_bits.total()) * config.cycle_hz(),
                          r.cyclic_bits.total(), config.bitrate);
    throw ConfigError({fmt::format(
        "can.sync.period: {:.1f} Hz with the {} layout needs {}: {:.1f} % cyclic "
        "(can.max_cyclic_load {:.1f} %), {:.1f} % with event PDOs at their inhibit times "
        "(can.max_bus_load {:.1f} %); lower the rate to at most {:.1f} Hz{} (dualv bus-load "
        "compares the layouts)",
        config.cycle_hz(), fw::to_string(r.layout), demand, 100.0 * r.cyclic_load,
        100.0 * config.max_cyclic_load, 100.0 * r.total_load, 100.0 * config.max_bus_load,
        r.max_rate_hz,
        config.bus_layout == fw::BusLayout::kPerDrive    ? " or use can.bus_layout: broadcast or fd"
        : config.bus_layout == fw::BusLayout::kBroadcast ? " or use can.bus_layout: fd"
                                                         : "")});
  }
  return r;
}

}  // namespace dualv::drivers
