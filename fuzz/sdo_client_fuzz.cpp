// The master's SDO client (drivers/canopen/sdo_client.hpp) against a hostile server: the
// fuzzer plays the drive, answering with any frame, late or never, while the client uploads
// into a buffer of fuzzed size or downloads a fuzzed payload (expedited or segmented).
// Checked besides ASan/UBSan, against CiA 301 7.2.4.3 and the client's documented contract:
//   - every frame the client sends is an SDO request to 600h + its node (decodes as one);
//   - an upload never reports more bytes than its buffer holds;
//   - a download that reports kDone sent exactly the payload: expedited in the initiate, or
//     in segments whose toggles alternate from 0 and whose last one alone carries c;
//   - the timeout: still busy at T - 1 ns after the last request, kTimeout and an abort
//     05040000h at T.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "drivers/canopen/sdo_client.hpp"
#include "firmware_if/firmware_if.hpp"
#include "fuzz/check.hpp"
#include "fuzz/frame_input.hpp"
#include "fuzz/recording_bus.hpp"

namespace fw = dualv::fw;
using dualv::drivers::canopen::SdoClient;
using dualv::drivers::canopen::SdoStatus;

namespace {

constexpr std::uint64_t kTimeoutNs = 10'000'000;

struct Transfer {
  bool upload = false;
  std::size_t first_frame = 0;     // bus frame number of the initiate request
  std::uint64_t last_request = 0;  // send time of the last request (not an abort)
  std::size_t requests_seen = 0;
};

// What the client sent for a download, read back with the firmware_if decoder.
void check_download_done(const dualv::fuzz::RecordingBus& bus, const Transfer& t,
                         std::span<const std::uint8_t> payload) {
  if (bus.count() - t.first_frame > dualv::fuzz::RecordingBus::kCapacity) return;  // not kept
  std::vector<std::uint8_t> sent;
  bool toggle = false, last_seen = false, expedited = false;
  for (std::size_t i = t.first_frame; i < bus.count(); ++i) {
    const auto m = fw::decode_sdo_request(bus.at(i).frame);
    FUZZ_CHECK(m.ok());
    if (i == t.first_frame) {
      FUZZ_CHECK(m->type == fw::SdoType::kDownloadInitiate);
      expedited = m->expedited;
      if (expedited)
        sent.assign(m->bytes().begin(), m->bytes().end());
      else
        FUZZ_CHECK(m->size_indicated && m->size == payload.size());
      continue;
    }
    FUZZ_CHECK(!expedited && !last_seen && m->type == fw::SdoType::kDownloadSegment);
    FUZZ_CHECK(m->toggle == toggle);
    toggle = !toggle;
    last_seen = m->last;
    sent.insert(sent.end(), m->bytes().begin(), m->bytes().end());
  }
  FUZZ_CHECK(expedited || last_seen);
  FUZZ_CHECK(std::equal(sent.begin(), sent.end(), payload.begin(), payload.end()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const auto node = static_cast<std::uint8_t>(1 + in.ConsumeIntegral<std::uint8_t>() % 127);
  dualv::fuzz::RecordingBus bus;
  SdoClient client(node, kTimeoutNs);
  std::array<std::uint8_t, 64> buffer{};
  std::array<std::uint8_t, 64> payload_storage{};
  std::span<const std::uint8_t> payload;
  std::size_t buffer_size = 0;
  Transfer t;
  bool refusing = false;

  auto start = [&] {
    const std::uint8_t how = in.ConsumeIntegral<std::uint8_t>();
    t = Transfer{};
    t.upload = (how & 1u) != 0;
    t.first_frame = bus.count();
    t.last_request = bus.now_ns;
    const auto index = in.ConsumeIntegral<std::uint16_t>();
    const auto sub = in.ConsumeIntegral<std::uint8_t>();
    if (t.upload) {
      buffer_size = in.ConsumeIntegralInRange<std::size_t>(0, buffer.size());
      (void)client.upload(bus, index, sub, std::span(buffer).first(buffer_size), bus.now_ns);
    } else {
      const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(0, payload_storage.size());
      for (std::size_t i = 0; i < n; ++i)
        payload_storage[i] = static_cast<std::uint8_t>(i * 37 + how);
      payload = std::span(payload_storage).first(n);
      (void)client.download(bus, index, sub, payload, bus.now_ns);
    }
  };

  start();
  while (in.remaining_bytes() > 0) {
    const SdoStatus before = client.status();
    const std::size_t sent_before = bus.count();
    const std::uint8_t op = in.ConsumeIntegral<std::uint8_t>();
    switch (op % 8) {
      case 0: {  // time passes, then the client checks its timeout
        const std::uint64_t since = bus.now_ns - t.last_request;
        const std::uint64_t dt = in.ConsumeIntegralInRange<std::uint64_t>(0, 2 * kTimeoutNs);
        bus.now_ns += dt;
        const SdoStatus s = client.poll(bus, bus.now_ns);
        if (before == SdoStatus::kBusy) {
          if (since + dt < kTimeoutNs) {
            FUZZ_CHECK(s == SdoStatus::kBusy);
          } else {
            FUZZ_CHECK(s == SdoStatus::kTimeout);
            if (!refusing) {  // the abort went out (a refused send leaves nothing to check)
              FUZZ_CHECK(bus.count() == sent_before + 1);
              const auto m = fw::decode_sdo_request(bus.at(sent_before).frame);
              FUZZ_CHECK(m.ok() && m->type == fw::SdoType::kAbort &&
                         m->abort_code == static_cast<std::uint32_t>(fw::SdoAbortCode::kTimeout));
            }
          }
        }
        break;
      }
      case 1:
        client.cancel(bus);
        FUZZ_CHECK(client.status() == SdoStatus::kIdle);
        break;
      case 2:
        if (!client.busy()) start();
        break;
      case 3:
        refusing = (op & 0x80u) != 0;
        bus.refuse_sends(refusing);
        break;
      default: {  // a frame from "the server": mostly on 580h + node, DLC 8
        fw::CanFrame f = dualv::fuzz::consume_frame(in);
        if ((op & 0x10u) == 0) {
          f.id = fw::kSdoTxBase + node;
          f.extended = f.rtr = false;
          if ((op & 0x20u) == 0) f.dlc = 8;
        }
        const bool ours = client.on_frame(bus, f, bus.now_ns);
        FUZZ_CHECK(ours == (!f.extended && f.id == fw::kSdoTxBase + node));
        break;
      }
    }
    // Every frame sent since is a request from this client.
    for (std::size_t i = sent_before; i < bus.count(); ++i) {
      const fw::CanFrame& f = bus.at(i).frame;
      FUZZ_CHECK(!f.extended && !f.rtr && f.id == fw::kSdoRxBase + node && f.dlc == 8);
      const auto m = fw::decode_sdo_request(f);
      FUZZ_CHECK(m.ok() && m->node == node);
      if (m->type != fw::SdoType::kAbort) t.last_request = bus.at(i).time_ns;
    }
    FUZZ_CHECK(client.uploaded().size() <= buffer_size || !t.upload);
    if (client.status() == SdoStatus::kDone && before == SdoStatus::kBusy) {
      if (t.upload)
        FUZZ_CHECK(client.uploaded().size() <= buffer_size);
      else
        check_download_done(bus, t, payload);
    }
  }
  return 0;
}
