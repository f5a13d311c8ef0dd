#!/usr/bin/env python3
"""Writes the seed corpus fuzz/corpus/<target>/ from hand-computed frames (CiA 301 / 402)
and the shipped configuration. Run from anywhere; rewrites the seeds it owns, keeps the
rest (inputs the fuzzer found and that were checked in as regression seeds)."""
import os
import struct

ROOT = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(ROOT)


def frame(cob_id, data=b"", rtr=False, dlc=None):
    """12 bytes as fuzz/frame_input.hpp reads them: id u16 LE, flags, DLC, 8 data bytes."""
    data = bytes(data)
    return struct.pack("<HBB", cob_id, 1 if rtr else 0, len(data) if dlc is None else dlc) + \
        data.ljust(8, b"\0")


def write(target, name, payload):
    d = os.path.join(ROOT, "corpus", target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(payload)


# ---- firmware_if_decoders: one frame (+ segments for the reassembly) ----------------------
FRAMES = {
    "nmt_start_all": frame(0x000, [0x01, 0x00]),               # CiA 301 7.2.8.3.1
    "nmt_reset_node3": frame(0x000, [0x81, 0x03]),
    "sync": frame(0x080),                                       # 7.2.5, DLC 0
    "sync_counter": frame(0x080, [0x05]),
    "heartbeat_operational": frame(0x701, [0x05]),              # 7.2.8.3.2.2
    "bootup": frame(0x702, [0x00]),
    "emcy_overcurrent": frame(0x083, [0x10, 0x23, 0x03, 0, 0, 0, 0, 0]),  # 2310h, reg 03h
    "emcy_reset": frame(0x084, [0, 0, 0, 0, 0, 0, 0, 0]),
    "rpdo1_enable_torque": frame(0x201, [0x0F, 0x00, 0xE8, 0x03]),  # cw 000Fh, 1000 per mille
    "tpdo1": frame(0x181, [0x27, 0x06, 0x00, 0x00, 0x10, 0x00]),    # sw 0627h, position
    "broadcast_rpdo": frame(0x200, [0x10, 0x00, 0xF0, 0xFF, 0x00, 0x00, 0x01, 0x00]),
    "controlword_rpdo": frame(0x202, [0x06, 0x00]),
    "sdo_upload_request": frame(0x601, [0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]),
    "sdo_download_u16": frame(0x601, [0x2B, 0x72, 0x60, 0x00, 0xE8, 0x03, 0, 0]),
    "sdo_upload_response_u16": frame(0x581, [0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0, 0]),
    "sdo_abort": frame(0x581, [0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x02, 0x06]),
    "sdo_segmented_upload_response": frame(0x581, [0x41, 0x08, 0x10, 0x00, 0x0A, 0, 0, 0]),
    "extended": frame(0x1234, [1, 2, 3]),
    "rtr": frame(0x701, rtr=True),
}
for name, f in FRAMES.items():
    write("firmware_if_decoders", name, f)
# A segmented upload of 10 bytes into a 16-byte buffer: capacity, announced size (as
# FuzzedDataProvider takes integers: from the end of the data), then two segments.
segments = frame(0x581, [0x00, ord("D"), ord("u"), ord("a"), ord("l"), ord("-"), ord("V"), ord(" ")]) + \
    frame(0x581, [0x1B, ord("R"), ord("R"), ord("R"), 0, 0, 0, 0])  # toggle 1, n = 4, c = 1
write("firmware_if_decoders", "segmented_upload",
      FRAMES["sdo_segmented_upload_response"] + segments + bytes([10, 16]))

# ---- sdo_client: node, transfer, then server frames -----------------------------------------
# Bytes: node (0 -> node 1), how (bit 0: upload), then integers taken from the END of the
# input by FuzzedDataProvider (index, subindex, size), ops with frames in between.
def client_seed(ops, tail):
    return bytes([0]) + bytes(ops) + bytes(tail)

write("sdo_client", "upload_expedited",
      client_seed([1] + [4] + list(frame(0x581, [0x4B, 0x41, 0x60, 0x00, 0x37, 0x02])[4:]) + [4],
                  [16, 0x00, 0x41, 0x60]))
write("sdo_client", "download_segmented",
      client_seed([0, 4] + list(frame(0x581, [0x60, 0x08, 0x10, 0x00])[4:]) +
                  [4] + list(frame(0x581, [0x20])[4:]) + [4] + list(frame(0x581, [0x30])[4:]) +
                  [0, 0], [20, 0x00, 0x08, 0x10]))
write("sdo_client", "timeout", client_seed([1, 0, 0, 0, 0], [8, 0, 0x41, 0x60, 0xFF, 0xFF]))

# ---- command_verifier: op bytes with fields (the target builds and signs the messages) ------
write("command_verifier", "signed_reset", bytes([0x01, 4, 0, 0, 0, 0, 0, 0, 1] + [0x10] * 16))
write("command_verifier", "estop_unsigned", bytes([0x09, 3] + [0] * 16))
write("command_verifier", "setpoint", bytes([0x03] + list(range(1, 40))))
write("command_verifier", "altered", bytes([0x21, 2] + [7] * 24))
write("command_verifier", "raw_bytes", bytes([0x00, 40]) + b"\x00" * 40)

# ---- robot_config / program: the shipped files and damaged copies ---------------------------
with open(os.path.join(REPO, "config", "dualv.yaml"), "rb") as f:
    cfg = f.read()
write("robot_config", "dualv.yaml", cfg)
for pct in (50, 75, 99):
    write("robot_config", f"dualv_truncated_{pct}.yaml", cfg[: len(cfg) * pct // 100])
write("robot_config", "empty.yaml", b"")
write("robot_config", "duplicate_key.yaml", cfg.replace(b"safety:", b"safety:\n  torque: {max: 600}\nsafety_:", 1))
with open(os.path.join(REPO, "config", "paper.yaml"), "rb") as f:
    paper = f.read()
write("program", "paper.yaml", paper)
write("program", "short_ptp.yaml", b"program:\n  segments:\n    - ptp: {to: [0.01, 0.0, 0.0], duration: 0.0004}\n")
write("program", "custom_shape.yaml",
      b"program:\n  segments:\n    - shape: {type: custom, T: 0.5, timing: retimed, tau: 0.1,\n"
      b"        terms: {x: [{a: 0.01, alpha: 0, n1: 1, b: 0, beta: 0, n2: 1}], y: [], theta: []}}\n")
write("program", "auto_tau.yaml",
      b"program:\n  segments:\n    - shape: {type: ellipse, T: 0.4, timing: smooth, tau: auto}\n    - dwell: {duration: 0.1}\n")

# ---- bus_attack: per cycle a control byte and its frames ------------------------------------
write("bus_attack", "quiet", bytes(60))
write("bus_attack", "forged_emcy", bytes(30) + bytes([0x01]) + frame(0x082, [0x10, 0x23, 0x03, 0, 0, 0, 0, 0]) + bytes(20))
write("bus_attack", "forged_tpdo", bytes(30) + bytes([0x03]) + frame(0x181, [0x27, 0x06, 0, 0, 0, 0x40]) * 3 + bytes(20))
write("bus_attack", "nmt_stop_all", bytes(30) + bytes([0x01]) + frame(0x000, [0x02, 0x00]) + bytes(20))
write("bus_attack", "sdo_write_max_torque", bytes(30) + bytes([0x01]) + frame(0x601, [0x2B, 0x72, 0x60, 0x00, 0xFF, 0xFF]) + bytes(20))

# ---- eds: the shipped EDS (CiA 306) and damaged copies ---------------------------------------
with open(os.path.join(REPO, "config", "eds", "dualv-emulated-drive.eds"), "rb") as f:
    eds = f.read()
write("eds", "dualv-emulated-drive.eds", eds)
write("eds", "truncated_half.eds", eds[: len(eds) // 2])
# 60C2h without sub-index 2, SubNumber consistent (eds-check and sim --eds refuse it).
start = eds.index(b"[60C2sub2]\n")
no_sub = eds[:start] + eds[eds.index(b"\n[", start) + 1:]
write("eds", "record_without_sub2.eds",
      no_sub.replace(b"[60C2]\nParameterName=Interpolation time period\nObjectType=0x9\nSubNumber=3",
                     b"[60C2]\nParameterName=Interpolation time period\nObjectType=0x9\nSubNumber=2"))
write("eds", "nodeid_default.eds",
      b"[MandatoryObjects]\nSupportedObjects=1\n1=0x1014\n\n[1014]\nParameterName=COB-ID EMCY\n"
      b"ObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue=$NODEID+0x80\nPDOMapping=0\n")
write("eds", "duplicate_key.eds", eds.replace(b"AccessType=rw\n", b"AccessType=rw\nAccessType=ro\n", 1))
