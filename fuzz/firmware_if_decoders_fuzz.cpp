// Every firmware_if decoder on one fuzzed CAN frame (fuzz/frame_input.hpp), then a segmented
// SDO reassembly (fw::SdoSegmentReceiver) from the rest of the input. Besides ASan and UBSan,
// each decoder that accepts a frame must agree with its encoder: re-encoding the decoded value
// gives the same frame on the wire (PDO, EMCY, NMT, heartbeat, SYNC) or, for SDO, whose
// non-canonical forms (e = 1 without s) exist, a frame that decodes to the same message.
// And what firmware_if/*.hpp promises of every decoder: 29-bit and RTR frames are refused
// (CiA 301 7.3.5: the predefined connection set is 11-bit data frames).
#include <array>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "firmware_if/firmware_if.hpp"
#include "fuzz/check.hpp"
#include "fuzz/frame_input.hpp"

namespace fw = dualv::fw;

namespace {

template <class T>
void refused_unless_plain(const fw::Result<T>& r, const fw::CanFrame& f) {
  if (f.extended || f.rtr) FUZZ_CHECK(!r.ok());
}

// Same SDO message as far as the wire says it (size_indicated of an expedited frame and the
// size of a segmented initiate without s are not part of the canonical encoding).
bool same_sdo(const fw::SdoMessage& a, const fw::SdoMessage& b) {
  if (a.type != b.type || a.node != b.node) return false;
  const bool initiate = a.type == fw::SdoType::kDownloadInitiate ||
                        a.type == fw::SdoType::kUploadInitiate || a.type == fw::SdoType::kAbort;
  if (initiate && (a.index != b.index || a.subindex != b.subindex)) return false;
  if (a.type == fw::SdoType::kAbort) return a.abort_code == b.abort_code;
  if (a.expedited != b.expedited || a.toggle != b.toggle || a.last != b.last) return false;
  if (!a.expedited && a.size_indicated && (b.size != a.size || !b.size_indicated)) return false;
  const auto x = a.bytes(), y = b.bytes();
  return std::equal(x.begin(), x.end(), y.begin(), y.end());
}

// The canonical frame for an SDO message (request = client -> server); an error when the
// message has no canonical form (segmented initiate without a size: nothing to re-encode).
fw::Result<fw::CanFrame> encode_sdo(const fw::SdoMessage& m, bool request) {
  using fw::SdoType;
  switch (m.type) {
    case SdoType::kAbort:
      return fw::sdo_abort(m.node, request ? fw::SdoRole::kClient : fw::SdoRole::kServer, m.index,
                           m.subindex, m.abort_code);
    case SdoType::kDownloadInitiate:
      if (!request) return fw::sdo_download_initiate_response(m.node, m.index, m.subindex);
      if (m.expedited) return fw::sdo_download_expedited(m.node, m.index, m.subindex, m.bytes());
      if (m.size_indicated) return fw::sdo_download_initiate(m.node, m.index, m.subindex, m.size);
      return fw::Error::kBadValue;
    case SdoType::kDownloadSegment:
      return request ? fw::sdo_download_segment(m.node, m.toggle, m.bytes(), m.last)
                     : fw::sdo_download_segment_response(m.node, m.toggle);
    case SdoType::kUploadInitiate:
      if (request) return fw::sdo_upload_initiate(m.node, m.index, m.subindex);
      if (m.expedited)
        return fw::sdo_upload_expedited_response(m.node, m.index, m.subindex, m.bytes());
      if (m.size_indicated)
        return fw::sdo_upload_initiate_response(m.node, m.index, m.subindex, m.size);
      return fw::Error::kBadValue;
    case SdoType::kUploadSegment:
      return request ? fw::sdo_upload_segment_request(m.node, m.toggle)
                     : fw::sdo_upload_segment_response(m.node, m.toggle, m.bytes(), m.last);
  }
  return fw::Error::kBadValue;
}

void check_sdo(const fw::CanFrame& f, bool request) {
  const fw::Result<fw::SdoMessage> r =
      request ? fw::decode_sdo_request(f) : fw::decode_sdo_response(f);
  refused_unless_plain(r, f);
  if (!r) return;
  FUZZ_CHECK(f.dlc == 8);  // CiA 301 7.2.4.3: SDO frames are always 8 bytes
  FUZZ_CHECK(r->data_len <= (r->expedited ? fw::kSdoExpeditedMax : fw::kSdoSegmentMax));
  const fw::Result<fw::CanFrame> again = encode_sdo(*r, request);
  if (!again) return;
  const fw::Result<fw::SdoMessage> r2 =
      request ? fw::decode_sdo_request(*again) : fw::decode_sdo_response(*again);
  FUZZ_CHECK(r2.ok() && same_sdo(*r, *r2));
  FUZZ_CHECK(fw::decode_sdo_response(f, r->node).ok() == !request);
}

void check_frame(const fw::CanFrame& f) {
  using dualv::fuzz::same_wire;
  if (const auto c = fw::classify(f); c) {
    FUZZ_CHECK(!f.extended);
    FUZZ_CHECK(f.id == static_cast<std::uint32_t>(fw::function_base(c->function) + c->node));
  }
  if (const auto m = fw::decode_nmt(f); refused_unless_plain(m, f), m) {
    const auto e = fw::encode_nmt(m->command, m->node);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
  }
  if (const auto s = fw::decode_sync(f); refused_unless_plain(s, f), s) {
    const auto e = fw::encode_sync(s->counter);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
  }
  if (const auto h = fw::decode_heartbeat(f); refused_unless_plain(h, f), h) {
    const auto e = fw::encode_heartbeat(h->node, h->state);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
  }
  if (const auto m = fw::decode_emcy(f); refused_unless_plain(m, f), m) {
    const auto e = fw::encode_emcy(*m);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
    (void)fw::emcy_text(m->error_code);
  }
  if (const auto c = fw::decode_rpdo1(f); refused_unless_plain(c, f), c) {
    const auto e = fw::encode_rpdo1(static_cast<std::uint8_t>(f.id - fw::kRpdo1Base), *c);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
  }
  if (const auto fb = fw::decode_tpdo1(f); refused_unless_plain(fb, f), fb) {
    const auto e = fw::encode_tpdo1(static_cast<std::uint8_t>(f.id - fw::kTpdo1Base), *fb);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
  }
  if (const auto cw = fw::decode_controlword_rpdo(f); refused_unless_plain(cw, f), cw) {
    const auto e =
        fw::encode_controlword_rpdo(static_cast<std::uint8_t>(f.id - fw::kRpdo1Base), *cw);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
  }
  if (const auto b = fw::decode_broadcast_torques(f); refused_unless_plain(b, f), b) {
    FUZZ_CHECK(b->drives >= 1 && b->drives <= fw::kBroadcastMaxDrives);
    const auto e = fw::encode_broadcast_torques(*b);
    FUZZ_CHECK(e.ok() && same_wire(*e, f));
    for (std::uint8_t slot = 0; slot < fw::kBroadcastMaxDrives + 2; ++slot) {
      const auto t = fw::decode_broadcast_torque(f, slot);
      FUZZ_CHECK(t.ok() == (slot < b->drives));
      if (t) FUZZ_CHECK(*t == b->torque[slot]);
    }
  }
  if (const auto n = fw::pdo_node(f); n) FUZZ_CHECK(fw::is_valid_node_id(*n) || *n == 0);
  check_sdo(f, true);
  check_sdo(f, false);
  // CiA 402 words carried in the data bytes (CiA 402-2 tables 29, 30).
  const auto word = static_cast<std::uint16_t>(f.data[0] | (f.data[1] << 8));
  if (const auto sw = fw::decode_statusword(word); sw) {
    for (const fw::StatePattern& p : fw::kStatePatterns)
      if (p.state == sw->state) FUZZ_CHECK((word & p.mask) == p.value);
  }
  (void)fw::decode_command(word);
}

// A segmented transfer into a buffer of fuzzed size: never more bytes than the buffer or the
// announced size (CiA 301 7.2.4.3.4 / 7.2.4.3.7), toggles alternate from 0.
void check_reassembly(FuzzedDataProvider& in) {
  std::array<std::uint8_t, 64> storage{};
  const std::size_t cap = in.ConsumeIntegralInRange<std::size_t>(0, storage.size());
  const std::uint32_t announced = in.ConsumeIntegralInRange<std::uint32_t>(0, 80);
  fw::SdoSegmentReceiver rx(std::span(storage).first(cap));
  rx.begin(announced);
  bool toggle = false;
  std::size_t total = 0;
  while (in.remaining_bytes() > 0 && !rx.done()) {
    fw::CanFrame f = dualv::fuzz::consume_frame(in);
    f.id = fw::kSdoTxBase + 1;  // the segments of node 1's upload
    f.extended = f.rtr = false;
    f.dlc = 8;
    const auto m = fw::decode_sdo_response(f, 1);
    if (!m) continue;
    const fw::Error e = rx.accept(*m);
    if (e == fw::Error::kNone || e == fw::Error::kSizeMismatch) {  // the segment was taken
      // The receiver takes either segment type (it serves a client's upload and a server's
      // download; its caller dispatches by type): data-less ones count as 0 bytes.
      FUZZ_CHECK(
          (m->type == fw::SdoType::kUploadSegment || m->type == fw::SdoType::kDownloadSegment) &&
          m->toggle == toggle);
      toggle = !toggle;
      total += m->data_len;
    }
    FUZZ_CHECK(rx.bytes().size() == total && total <= cap);
    if (announced != 0) FUZZ_CHECK(total <= announced);
    if (rx.done() && e == fw::Error::kNone && announced != 0) FUZZ_CHECK(total == announced);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  check_frame(dualv::fuzz::frame_from(data, size));
  if (size > dualv::fuzz::kFrameBytes) {
    FuzzedDataProvider in(data + dualv::fuzz::kFrameBytes, size - dualv::fuzz::kFrameBytes);
    check_reassembly(in);
  }
  return 0;
}
